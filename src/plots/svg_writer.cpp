#include "plots/svg_writer.hpp"

#include <cassert>
#include <charconv>
#include <cmath>

namespace isowrench::plots {

std::string Num(double value, int decimals) {
  if (!std::isfinite(value)) return "0";
  char buffer[64];
  auto result =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, decimals);
  std::string s(buffer, result.ptr);
  // "-0.000" -> "0.000"
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string Exact(double value) {
  char buffer[64];
  auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string XmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {
std::string AttributeText(const Attributes& attributes) {
  std::string out;
  for (const auto& [name, value] : attributes) out += " " + name + "=\"" + XmlEscape(value) + "\"";
  return out;
}
}  // namespace

SvgWriter::SvgWriter(double width, double height, const std::string& title)
    : width_(width), height_(height), title_(title) {}

void SvgWriter::Element(const std::string& tag, const Attributes& attributes,
                        const std::string& text) {
  body_ += std::string(2 * depth_, ' ') + "<" + tag + AttributeText(attributes);
  body_ += text.empty() ? "/>\n" : ">" + XmlEscape(text) + "</" + tag + ">\n";
}

void SvgWriter::Open(const std::string& tag, const Attributes& attributes) {
  body_ += std::string(2 * depth_, ' ') + "<" + tag + AttributeText(attributes) + ">\n";
  open_.push_back(tag);
  ++depth_;
}

void SvgWriter::Close() {
  assert(!open_.empty() && "SvgWriter::Close without Open");
  --depth_;
  body_ += std::string(2 * depth_, ' ') + "</" + open_.back() + ">\n";
  open_.pop_back();
}

void SvgWriter::Line(double x1, double y1, double x2, double y2, const std::string& stroke,
                     double width, Attributes extra) {
  Attributes a = {{"x1", Num(x1)}, {"y1", Num(y1)},    {"x2", Num(x2)},
                  {"y2", Num(y2)}, {"stroke", stroke}, {"stroke-width", Num(width, 2)}};
  a.insert(a.end(), extra.begin(), extra.end());
  Element("line", a);
}

void SvgWriter::Text(double x, double y, const std::string& text, double size,
                     const std::string& anchor, Attributes extra) {
  Attributes a = {{"x", Num(x, 1)}, {"y", Num(y, 1)}, {"font-size", Num(size, 1)}};
  if (anchor != "start") a.push_back({"text-anchor", anchor});
  a.insert(a.end(), extra.begin(), extra.end());
  Element("text", a, text.empty() ? " " : text);
}

std::string SvgWriter::Finish(bool xml_declaration) {
  while (!open_.empty()) Close();
  std::string out;
  if (xml_declaration) out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + Num(width_, 0) +
         "\" height=\"" + Num(height_, 0) + "\" viewBox=\"0 0 " + Num(width_, 0) + " " +
         Num(height_, 0) + "\" font-family=\"Helvetica, Arial, sans-serif\">\n";
  out += "  <title>" + XmlEscape(title_) + "</title>\n";
  out += "  <rect x=\"0\" y=\"0\" width=\"" + Num(width_, 0) + "\" height=\"" + Num(height_, 0) +
         "\" fill=\"white\"/>\n";
  out += body_;
  out += "</svg>\n";
  return out;
}

}  // namespace isowrench::plots
