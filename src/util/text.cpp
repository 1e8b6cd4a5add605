#include "util/text.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

#include "isowrench/error.hpp"

namespace isowrench::util {

bool ParseDouble(std::string_view text, double* value) {
  std::string trimmed = Trim(text);
  if (trimmed.empty()) return false;
  const char* begin = trimmed.data();
  const char* end = begin + trimmed.size();
  if (*begin == '+') ++begin;  // from_chars rejects a leading '+'
  auto result = std::from_chars(begin, end, *value);
  return result.ec == std::errc() && result.ptr == end;
}

double ParseDoubleOrThrow(std::string_view text, const std::string& context) {
  double value = 0.0;
  if (!ParseDouble(text, &value)) {
    throw Error(context + ": '" + std::string(text) + "' is not a number");
  }
  return value;
}

std::vector<std::string> Split(std::string_view text, std::string_view separators) {
  std::vector<std::string> pieces;
  size_t start = 0;
  while (start <= text.size()) {
    size_t stop = text.find_first_of(separators, start);
    if (stop == std::string_view::npos) stop = text.size();
    std::string piece = Trim(text.substr(start, stop - start));
    if (!piece.empty()) pieces.push_back(piece);
    start = stop + 1;
  }
  return pieces;
}

std::string Trim(std::string_view text) {
  const char* blanks = " \t\r\n";
  size_t first = text.find_first_not_of(blanks);
  if (first == std::string_view::npos) return "";
  size_t last = text.find_last_not_of(blanks);
  return std::string(text.substr(first, last - first + 1));
}

std::string FormatNumber(double value, int significant) {
  char buffer[64];
  if (value == 0.0) value = 0.0;  // never "-0"
  // %g is locale dependent only for the decimal point; std::to_chars is not.
  auto result = std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general,
                              significant);
  return std::string(buffer, result.ptr);
}

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    if (i) out += separator;
    out += items[i];
  }
  return out;
}

}  // namespace isowrench::util
