#pragma once
// Private: a tiny SVG/XML writer. Numbers are formatted locale-independently; text and attribute
// values are escaped. Produces self-contained SVG (no external references).

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace isowrench::plots {

using Attributes = std::vector<std::pair<std::string, std::string>>;

/// Fixed-point number with `decimals` digits after '.', never "-0", locale independent.
std::string Num(double value, int decimals = 3);
/// Shortest round-trip representation (up to 17 significant digits), locale independent.
std::string Exact(double value);
/// Escape & < > " ' for XML text and attribute values.
std::string XmlEscape(std::string_view text);

class SvgWriter {
 public:
  /// Start a document of width x height px. `title` becomes the <title> element.
  SvgWriter(double width, double height, const std::string& title);

  /// <tag attrs>text</tag> (or <tag attrs/> when text is empty).
  void Element(const std::string& tag, const Attributes& attributes, const std::string& text = {});
  /// <tag attrs> ... Close().
  void Open(const std::string& tag, const Attributes& attributes);
  void Close();

  void Line(double x1, double y1, double x2, double y2, const std::string& stroke, double width,
            Attributes extra = {});
  /// Text at (x, y); anchor "start" | "middle" | "end".
  void Text(double x, double y, const std::string& text, double size = 11,
            const std::string& anchor = "start", Attributes extra = {});

  /// The finished document; `xml_declaration` false for inlining into HTML.
  std::string Finish(bool xml_declaration = true);

 private:
  std::string body_;
  std::vector<std::string> open_;
  double width_, height_;
  std::string title_;
  int depth_ = 1;
};

}  // namespace isowrench::plots
