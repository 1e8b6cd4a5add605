#pragma once
// Helpers to read SVG back with tinyxml2: find elements by class, read numeric attributes.

#include <tinyxml2.h>

#include <Eigen/Core>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

namespace isowrench_test {

/// True if the space-separated class attribute of `e` holds `cls`.
inline bool HasClass(const tinyxml2::XMLElement* e, const std::string& cls) {
  const char* attr = e->Attribute("class");
  if (!attr) return false;
  std::string s = " " + std::string(attr) + " ";
  return s.find(" " + cls + " ") != std::string::npos;
}

/// All descendants of `root` (depth first, document order) that satisfy `pred`.
inline void Collect(const tinyxml2::XMLElement* root,
                    const std::function<bool(const tinyxml2::XMLElement*)>& pred,
                    std::vector<const tinyxml2::XMLElement*>* out) {
  for (const tinyxml2::XMLElement* c = root->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (pred(c)) out->push_back(c);
    Collect(c, pred, out);
  }
}

inline std::vector<const tinyxml2::XMLElement*> ByClass(const tinyxml2::XMLElement* root,
                                                        const std::string& cls) {
  std::vector<const tinyxml2::XMLElement*> out;
  Collect(
      root, [&](const tinyxml2::XMLElement* e) { return HasClass(e, cls); }, &out);
  return out;
}

inline std::vector<const tinyxml2::XMLElement*> ByTag(const tinyxml2::XMLElement* root,
                                                      const std::string& tag) {
  std::vector<const tinyxml2::XMLElement*> out;
  Collect(
      root, [&](const tinyxml2::XMLElement* e) { return tag == e->Name(); }, &out);
  return out;
}

/// Numeric attribute (the SVG writes '.' decimals; strtod under the "C" locale of the tests).
inline double Num(const tinyxml2::XMLElement* e, const char* name) {
  const char* attr = e->Attribute(name);
  return attr ? std::strtod(attr, nullptr) : std::nan("");
}

/// Line geometry: start and end points in px.
struct LineGeom {
  Eigen::Vector2d a, b;
  Eigen::Vector2d d() const { return b - a; }
};
inline LineGeom Line(const tinyxml2::XMLElement* e) {
  return {{Num(e, "x1"), Num(e, "y1")}, {Num(e, "x2"), Num(e, "y2")}};
}

/// Concatenated text of every <text> under `root` (newline separated).
inline std::string AllText(const tinyxml2::XMLElement* root) {
  std::string out;
  for (const tinyxml2::XMLElement* t : ByTag(root, "text")) {
    if (t->GetText()) out += std::string(t->GetText()) + "\n";
  }
  return out;
}

/// Every attribute value in the document, for "no external reference" checks.
inline void AllAttributes(const tinyxml2::XMLElement* root, std::vector<std::string>* out) {
  for (const tinyxml2::XMLAttribute* a = root->FirstAttribute(); a; a = a->Next()) {
    out->push_back(std::string(a->Name()) + "=" + a->Value());
  }
  for (const tinyxml2::XMLElement* c = root->FirstChildElement(); c; c = c->NextSiblingElement()) {
    AllAttributes(c, out);
  }
}

}  // namespace isowrench_test
