// The wrap parts of the description (include/isowrench/model.hpp): names, quadrants, poses, and
// the checks Model construction runs on wrap objects and muscles' wrap lists.

#include <cmath>
#include <set>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/wrap.hpp"
#include "util/text.hpp"
#include "wrap/wrap_impl.hpp"

namespace isowrench {
namespace {

std::string WrapNum(double v) { return util::FormatNumber(v, 6); }

}  // namespace

const char* WrapShapeName(WrapShape shape) {
  switch (shape) {
    case WrapShape::kCylinder: return "cylinder";
    case WrapShape::kSphere: return "sphere";
    case WrapShape::kEllipsoid: return "ellipsoid";
    case WrapShape::kTorus: return "torus";
  }
  return "?";
}

const char* WrapMethodName(WrapMethod method) {
  switch (method) {
    case WrapMethod::kHybrid: return "hybrid";
    case WrapMethod::kMidpoint: return "midpoint";
    case WrapMethod::kAxial: return "axial";
  }
  return "?";
}

const char* WrapModeName(WrapMode mode) { return mode == WrapMode::kExact ? "exact" : "opensim"; }

WrapMode ParseWrapMode(const std::string& text) {
  if (text == "opensim") return WrapMode::kOpenSim;
  if (text == "exact") return WrapMode::kExact;
  throw Error("wrap mode '" + text + "' is not one of opensim, exact");
}

// WrapObject::extendFinalizeFromProperties: the accepted spellings.
WrapQuadrant WrapQuadrant::Parse(const std::string& text) {
  if (text == "all" || text == "All" || text == "ALL" || text == "Unassigned") return {};
  const std::string t = text;
  int sign = 1;
  std::string letter = t;
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) {
    sign = t[0] == '-' ? -1 : 1;
    letter = t.substr(1);
  }
  if (letter.size() == 1) {
    const char c = letter[0];
    if (c == 'x' || c == 'X') return {0, sign};
    if (c == 'y' || c == 'Y') return {1, sign};
    if (c == 'z' || c == 'Z') return {2, sign};
  }
  throw Error("quadrant '" + text + "' is not one of all, +x, -x, +y, -y, +z, -z (x = +x)");
}

std::string WrapQuadrant::ToString() const {
  if (sign == 0) return "all";
  return std::string(sign > 0 ? "+" : "-") + "xyz"[axis];
}

Eigen::Isometry3d WrapObjectSpec::Pose() const {
  // Simbody Rotation::setRotationToBodyFixedXYZ: R = Rx(a) Ry(b) Rz(c).
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = (Eigen::AngleAxisd(xyz_body_rotation.x(), Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(xyz_body_rotation.y(), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(xyz_body_rotation.z(), Eigen::Vector3d::UnitZ()))
                   .toRotationMatrix();
  X.translation() = translation;
  return X;
}

WrapSurface WrapSurface::From(const WrapObjectSpec& object) {
  WrapSurface s;
  s.shape = object.shape;
  s.radius = object.radius;
  s.length = object.length;
  s.radii = object.radii;
  s.inner_radius = object.inner_radius;
  s.outer_radius = object.outer_radius;
  s.quadrant = object.quadrant;
  return s;
}

std::string WrapStatusText(unsigned status) {
  static const std::pair<unsigned, const char*> kTexts[] = {
      {kWrapBelowStraightLine, "wrapped length below the straight line (OpenSim's algorithm)"},
      {kWrapNotConverged, "an iteration did not converge"},
      {kWrapNegativeArc, "negative arc (OpenSim's far-side sphere wrap)"},
      {kWrapDegenerate, "degenerate geometry (OpenSim would give NaN or reuse a previous result)"},
      {kWrapExactFallback, "no exact path on OpenSim's side: OpenSim's path used"},
      {kWrapRangeEmpty, "a wrap range holds no active point: later wraps not applied"},
  };
  std::string text;
  for (const auto& [bit, words] : kTexts) {
    if (status & bit) text += (text.empty() ? "" : "; ") + std::string(words);
  }
  return text;
}

void CheckWraps(const LimbDescription& d, const std::string& model) {
  std::set<std::string> links(d.links.begin(), d.links.end());
  links.insert(d.root_link);
  std::set<std::string> names;
  std::vector<std::string> object_names;
  for (const WrapObjectSpec& w : d.wrap_objects) {
    const std::string what = model + ", wrap object '" + w.name + "' (" + WrapShapeName(w.shape) +
                             " on '" + w.link + "')";
    if (w.name.empty()) throw Error(model + ": a wrap object on '" + w.link + "' has no name");
    if (!names.insert(w.name).second) throw Error(what + " is defined twice");
    object_names.push_back(w.name);
    if (!links.count(w.link)) {
      throw Error(what + ": link '" + w.link + "' is not on the chain" +
                  DidYouMean(w.link, d.links));
    }
    if (!w.translation.allFinite() || !w.xyz_body_rotation.allFinite()) {
      throw Error(what + ": translation or xyz_body_rotation is not finite");
    }
    auto positive = [&](double value, const char* name) {
      if (!std::isfinite(value) || !(value > 0.0)) {
        throw Error(what + ": " + name + " " + WrapNum(value) + " m must be finite and > 0");
      }
    };
    switch (w.shape) {
      case WrapShape::kCylinder:
        positive(w.radius, "radius");
        positive(w.length, "length");
        break;
      case WrapShape::kSphere: positive(w.radius, "radius"); break;
      case WrapShape::kEllipsoid:
        for (int i = 0; i < 3; ++i)
          positive(w.radii[i], i == 0 ? "radius x" : i == 1 ? "radius y" : "radius z");
        break;
      case WrapShape::kTorus:
        positive(w.inner_radius, "inner_radius");
        positive(w.outer_radius, "outer_radius");
        if (!(w.inner_radius < w.outer_radius)) {
          throw Error(what + ": inner_radius " + WrapNum(w.inner_radius) +
                      " m must be below outer_radius " + WrapNum(w.outer_radius) +
                      " m (the tube would cross the axis)");
        }
        break;
    }
    if (w.quadrant.sign < -1 || w.quadrant.sign > 1 ||
        (w.quadrant.sign != 0 && (w.quadrant.axis < 0 || w.quadrant.axis > 2))) {
      throw Error(what + ": quadrant (axis " + std::to_string(w.quadrant.axis) + ", sign " +
                  std::to_string(w.quadrant.sign) + ") is not one of all, +-x, +-y, +-z");
    }
  }
  for (const MuscleSpec& m : d.muscles) {
    const int n = static_cast<int>(m.path.size());
    for (size_t k = 0; k < m.wraps.size(); ++k) {
      const PathWrapSpec& w = m.wraps[k];
      const std::string what = model + ", muscle '" + m.name + "', wrap " + std::to_string(k + 1) +
                               " ('" + w.object + "')";
      if (!names.count(w.object)) {
        throw Error(what + ": no wrap object is called '" + w.object + "'" +
                    DidYouMean(w.object, object_names) +
                    (object_names.empty()
                         ? "; the model has no wrap objects"
                         : "; the wrap objects are " + util::Join(object_names, ", ")));
      }
      auto valid = [&](int i) { return i == -1 || (i >= 1 && i <= n); };
      if (!valid(w.range_first) || !valid(w.range_last) ||
          (w.range_first != -1 && w.range_last != -1 && w.range_first > w.range_last)) {
        throw Error(what + ": range " + std::to_string(w.range_first) + " " +
                    std::to_string(w.range_last) + " is outside the path's " + std::to_string(n) +
                    " points (1-based point numbers, -1 = the first/last point, first <= last)");
      }
    }
  }
}

}  // namespace isowrench
