#pragma once
// Private helpers: locale-independent number parsing and small string utilities.

#include <string>
#include <string_view>
#include <vector>

namespace isowrench::util {

/// Parse a whole string as a double, independent of the C/C++ locale (std::from_chars).
/// Returns false if the text is not entirely a number. "nan"/"inf" parse (then check finite).
bool ParseDouble(std::string_view text, double* value);

/// ParseDouble that throws isowrench::Error("<context>: '<text>' is not a number").
double ParseDoubleOrThrow(std::string_view text, const std::string& context);

/// Split on any of `separators`, dropping empty pieces, trimming blanks.
std::vector<std::string> Split(std::string_view text, std::string_view separators);

std::string Trim(std::string_view text);

/// Format with %g-like precision, locale independent.
std::string FormatNumber(double value, int significant = 6);

/// Join strings with a separator.
std::string Join(const std::vector<std::string>& items, const std::string& separator);

}  // namespace isowrench::util
