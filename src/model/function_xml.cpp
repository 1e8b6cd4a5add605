// The function elements of the URDF extension <-> isowrench::Function.

#include "model/function_xml.hpp"

#include <cstring>
#include <sstream>
#include <vector>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

constexpr const char* kFunctionTagPrefix = "isowrench:";
constexpr FunctionKind kKinds[] = {
    FunctionKind::kConstant,           FunctionKind::kLinear,          FunctionKind::kSimmSpline,
    FunctionKind::kNaturalCubicSpline, FunctionKind::kPiecewiseLinear, FunctionKind::kPolynomial,
    FunctionKind::kMultiplier};

// The kind named by an element, or false.
bool KindOf(const tinyxml2::XMLElement& e, FunctionKind* kind) {
  const char* name = e.Name();
  const size_t prefix = std::strlen(kFunctionTagPrefix);
  if (std::strncmp(name, kFunctionTagPrefix, prefix) != 0) return false;
  for (FunctionKind k : kKinds) {
    if (std::strcmp(name + prefix, FunctionKindName(k)) == 0) {
      *kind = k;
      return true;
    }
  }
  return false;
}

std::string KindList() {
  std::vector<std::string> names;
  for (FunctionKind k : kKinds)
    names.push_back(std::string(kFunctionTagPrefix) + FunctionKindName(k));
  return util::Join(names, ", ");
}

struct Parser {
  const tinyxml2::XMLElement& e;
  const std::string& source;

  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(source + ":" + std::to_string(e.GetLineNum()) + ": <" + e.Name() + ">: " + what);
  }

  std::string Text(const char* name) const {
    const char* value = e.Attribute(name);
    if (!value) Fail(std::string("needs the attribute '") + name + "'");
    return value;
  }

  std::vector<double> Numbers(const char* name) const {
    const std::string text = Text(name);
    std::vector<double> values;
    for (const std::string& piece : util::Split(text, " \t\r\n,")) {
      double v = 0.0;
      if (!util::ParseDouble(piece, &v)) {
        Fail(std::string("attribute '") + name + "' holds '" + piece + "', which is not a number");
      }
      values.push_back(v);
    }
    return values;
  }

  double Number(const char* name) const {
    std::vector<double> v = Numbers(name);
    if (v.size() != 1) {
      Fail(std::string("attribute '") + name + "' = '" + Text(name) + "' must be one number");
    }
    return v[0];
  }
};

}  // namespace

bool IsFunctionElement(const tinyxml2::XMLElement& e) {
  FunctionKind kind;
  return KindOf(e, &kind);
}

Function ParseFunctionXml(const tinyxml2::XMLElement& e, const std::string& source) {
  Parser p{e, source};
  FunctionKind kind;
  if (!KindOf(e, &kind)) {
    p.Fail("unknown function element; expected one of " + KindList());
  }
  try {
    switch (kind) {
      case FunctionKind::kConstant: return Function::Constant(p.Number("value"));
      case FunctionKind::kLinear: return Function::Linear(p.Number("slope"), p.Number("intercept"));
      case FunctionKind::kSimmSpline: return Function::SimmSpline(p.Numbers("x"), p.Numbers("y"));
      case FunctionKind::kNaturalCubicSpline:
        return Function::NaturalCubicSpline(p.Numbers("x"), p.Numbers("y"));
      case FunctionKind::kPiecewiseLinear:
        return Function::PiecewiseLinear(p.Numbers("x"), p.Numbers("y"));
      case FunctionKind::kPolynomial: return Function::Polynomial(p.Numbers("coefficients"));
      case FunctionKind::kMultiplier: {
        double scale = p.Number("scale");
        Function inner = ParseFunctionChild(e, source);
        return Function::Multiplier(std::move(inner), scale);
      }
    }
  } catch (const Error& error) {
    // Messages from the factories carry no location; ours already start with the source.
    const std::string what = error.what();
    if (what.compare(0, source.size() + 1, source + ":") == 0) throw;
    p.Fail(what);
  }
  p.Fail("unhandled function kind");
}

Function ParseFunctionChild(const tinyxml2::XMLElement& parent, const std::string& source) {
  const tinyxml2::XMLElement* found = nullptr;
  for (const tinyxml2::XMLElement* c = parent.FirstChildElement(); c; c = c->NextSiblingElement()) {
    const bool is_function =
        IsFunctionElement(*c) ||
        std::strncmp(c->Name(), kFunctionTagPrefix, std::strlen(kFunctionTagPrefix)) == 0;
    if (!is_function) continue;
    if (!IsFunctionElement(*c)) {
      throw Error(source + ":" + std::to_string(c->GetLineNum()) + ": <" + c->Name() +
                  "> inside <" + parent.Name() + "> is not a function element; expected one of " +
                  KindList());
    }
    if (found) {
      throw Error(source + ":" + std::to_string(c->GetLineNum()) + ": <" + parent.Name() +
                  "> holds a second function element <" + c->Name() + "> (line " +
                  std::to_string(found->GetLineNum()) + " has the first); it takes exactly one");
    }
    found = c;
  }
  if (!found) {
    throw Error(source + ":" + std::to_string(parent.GetLineNum()) + ": <" + parent.Name() +
                "> needs one function element (" + KindList() + ")");
  }
  return ParseFunctionXml(*found, source);
}

std::string FunctionXmlText(const Function& f, const std::string& indent) {
  auto n = [](double v) { return util::FormatNumber(v, 17); };
  auto list = [&n](const std::vector<double>& v) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + n(v[i]);
    return s;
  };
  std::ostringstream o;
  o << indent << "<" << kFunctionTagPrefix << FunctionKindName(f.kind());
  switch (f.kind()) {
    case FunctionKind::kConstant: o << " value=\"" << n(f.intercept()) << "\"/>\n"; break;
    case FunctionKind::kLinear:
      o << " slope=\"" << n(f.slope()) << "\" intercept=\"" << n(f.intercept()) << "\"/>\n";
      break;
    case FunctionKind::kSimmSpline:
    case FunctionKind::kNaturalCubicSpline:
    case FunctionKind::kPiecewiseLinear:
      o << " x=\"" << list(f.x()) << "\" y=\"" << list(f.y()) << "\"/>\n";
      break;
    case FunctionKind::kPolynomial:
      o << " coefficients=\"" << list(f.coefficients()) << "\"/>\n";
      break;
    case FunctionKind::kMultiplier:
      o << " scale=\"" << n(f.scale()) << "\">\n"
        << FunctionXmlText(f.inner(), indent + "  ") << indent << "</" << kFunctionTagPrefix
        << FunctionKindName(f.kind()) << ">\n";
      break;
  }
  return o.str();
}

}  // namespace isowrench
