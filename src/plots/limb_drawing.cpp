// Two-view stick figure of a limb (top: world x-y, side: world x-z) to check a URDF by eye.

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/wrap_report.hpp"
#include "plots/svg_writer.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

using plots::Num;

// Points closer than this (m) are one joint centre (a ball joint's three axes share one).
constexpr double kSameCentre = 1e-9;
// Fraction of the chain length used for axis segments when none is given.
constexpr double kAxisFraction = 0.12;
constexpr double kPad = 36;          // px around each view
constexpr double kBannerLines = 44;  // title and one subtitle line
constexpr double kSubtitleLine = 13;
constexpr double kViewTitle = 18;
constexpr double kFooter = 34;  // scale bar and legend

struct Segment3 {
  Eigen::Vector3d a, b;
};

struct Geometry {
  std::vector<Eigen::Vector3d> bones;  // chain polyline: root, each joint's child origin, endpoint
  struct Centre {
    Eigen::Vector3d p;
    std::vector<std::string> joints;
  };
  std::vector<Centre> centres;
  struct Axis {
    std::string joint;
    bool prismatic;
    Segment3 s;
  };
  std::vector<Axis> axes;
  struct Muscle {
    std::string name;
    std::vector<Eigen::Vector3d> points;       // the drawn path: path points, tangent points, arcs
    std::vector<Eigen::Vector3d> path_points;  // the active path points (red dots)
    struct Arc {
      std::string wrap;                     // wrap object name
      std::vector<Eigen::Vector3d> points;  // r1, samples on the surface, r2 (world)
    };
    std::vector<Arc> arcs;
  };
  std::vector<Muscle> muscles;
  struct Surface {
    std::string name;
    WrapShape shape;
    bool active;
    WrapSurface surface;
    Eigen::Isometry3d X_W_S;
  };
  std::vector<Surface> surfaces;
  Eigen::Isometry3d endpoint;
  Eigen::Matrix3d transducer;
};

// Samples (r1 and r2 included) of a wrap arc and points of a surface's outline.
constexpr int kArcSamples = 24;
constexpr int kOutlineSamples = 72;

// The wrap's arc from r1 to r2 (m, in S) over `surface`, drawn as `n` + 1 points: on a
// cylinder the helix (about the z axis) that goes round the side whose helix length is nearest
// |arc_length| (OpenSim's and the exact path are such helices); on a sphere the great circle, the
// short way or, where |arc_length| is nearer the long way's length (OpenSim's far-side wrap),
// the long way; on an ellipsoid and a torus the chord r1 -> r2 pushed onto the surface (radially
// from the centre; onto the tube from its ring), an illustration of where the path runs.
std::vector<Eigen::Vector3d> SampleWrapArc(const WrapSurface& s, const Eigen::Vector3d& r1,
                                           const Eigen::Vector3d& r2, double arc_length, int n) {
  std::vector<Eigen::Vector3d> out;
  const double target = std::abs(arc_length);
  switch (s.shape) {
    case WrapShape::kCylinder: {
      const double t1 = std::atan2(r1.y(), r1.x());
      double dt = std::remainder(std::atan2(r2.y(), r2.x()) - t1, 2 * M_PI);
      const double dz = r2.z() - r1.z();
      auto helix = [&](double a) { return std::hypot(s.radius * a, dz); };
      const double other = dt - std::copysign(2 * M_PI, dt == 0 ? 1.0 : dt);
      if (std::abs(helix(other) - target) < std::abs(helix(dt) - target)) dt = other;
      for (int i = 0; i <= n; ++i) {
        const double f = static_cast<double>(i) / n;
        const double a = t1 + f * dt;
        out.emplace_back(s.radius * std::cos(a), s.radius * std::sin(a), r1.z() + f * dz);
      }
      return out;
    }
    case WrapShape::kSphere: {
      const Eigen::Vector3d u1 = r1.normalized(), u2 = r2.normalized();
      Eigen::Vector3d axis = u1.cross(u2);
      const double angle = std::atan2(axis.norm(), u1.dot(u2));
      if (axis.norm() < 1e-12) axis = u1.unitOrthogonal();
      axis.normalize();
      double sweep = angle;
      if (std::abs(s.radius * (2 * M_PI - angle) - target) < std::abs(s.radius * angle - target))
        sweep = angle - 2 * M_PI;
      const Eigen::Vector3d v = axis.cross(u1);
      for (int i = 0; i <= n; ++i) {
        const double a = sweep * i / n;
        out.push_back(s.radius * (std::cos(a) * u1 + std::sin(a) * v));
      }
      return out;
    }
    case WrapShape::kEllipsoid:
    case WrapShape::kTorus:
      for (int i = 0; i <= n; ++i) {
        const double f = static_cast<double>(i) / n;
        const Eigen::Vector3d x = (1 - f) * r1 + f * r2;
        if (s.shape == WrapShape::kEllipsoid) {
          const double k = x.cwiseQuotient(s.radii).norm();
          out.push_back(k > 0 ? Eigen::Vector3d(x / k) : x);
        } else {
          Eigen::Vector3d ring(x.x(), x.y(), 0.0);
          ring = ring.norm() > 0 ? Eigen::Vector3d(s.outer_radius * ring.normalized())
                                 : Eigen::Vector3d(s.outer_radius, 0, 0);
          const Eigen::Vector3d off = x - ring;
          out.push_back(off.norm() > 0 ? Eigen::Vector3d(ring + s.inner_radius * off.normalized())
                                       : x);
        }
      }
      return out;
  }
  return out;
}

// A circle (m, in S) of radius r about the S z axis at height z.
std::vector<Eigen::Vector3d> WrapCircleS(double r, double z) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i <= kOutlineSamples; ++i) {
    const double a = 2 * M_PI * i / kOutlineSamples;
    out.emplace_back(r * std::cos(a), r * std::sin(a), z);
  }
  return out;
}

// The outline of a wrap surface seen along the view's third axis (orthographic), as closed or
// open polylines in world coordinates (right, up) of the view, m. A cylinder: its two end
// circles and the two silhouette lines (offset by the radius across the projected axis); a
// sphere: its circle; an ellipsoid: its shadow's ellipse (the 2 x 2 block of R diag(r^2) R^T);
// a torus: its equator's outer and inner circles and the circles along the top and bottom of
// the tube.
std::vector<std::vector<Eigen::Vector2d>> WrapOutline(const WrapSurface& s,
                                                      const Eigen::Isometry3d& X, int right,
                                                      int up) {
  std::vector<std::vector<Eigen::Vector2d>> out;
  auto project = [&](const std::vector<Eigen::Vector3d>& points_S) {
    std::vector<Eigen::Vector2d> p;
    for (const Eigen::Vector3d& x : points_S) {
      const Eigen::Vector3d w = X * x;
      p.emplace_back(w[right], w[up]);
    }
    out.push_back(p);
  };
  const Eigen::Vector2d c(X.translation()[right], X.translation()[up]);
  switch (s.shape) {
    case WrapShape::kCylinder: {
      project(WrapCircleS(s.radius, -0.5 * s.length));
      project(WrapCircleS(s.radius, 0.5 * s.length));
      const Eigen::Vector3d a = X.linear().col(2);
      const Eigen::Vector2d a2(a[right], a[up]);
      if (a2.norm() > 1e-9) {
        const Eigen::Vector2d n(-a2.y() / a2.norm(), a2.x() / a2.norm());
        const Eigen::Vector2d h = 0.5 * s.length * a2;
        for (double side : {-1.0, 1.0}) {
          out.push_back({c - h + side * s.radius * n, c + h + side * s.radius * n});
        }
      }
      break;
    }
    case WrapShape::kSphere: {
      std::vector<Eigen::Vector2d> p;
      for (int i = 0; i <= kOutlineSamples; ++i) {
        const double a = 2 * M_PI * i / kOutlineSamples;
        p.push_back(c + s.radius * Eigen::Vector2d(std::cos(a), std::sin(a)));
      }
      out.push_back(p);
      break;
    }
    case WrapShape::kEllipsoid: {
      const Eigen::Matrix3d M =
          X.linear() * s.radii.cwiseAbs2().asDiagonal() * X.linear().transpose();
      Eigen::Matrix2d B;
      B << M(right, right), M(right, up), M(up, right), M(up, up);
      const Eigen::Matrix2d L = B.llt().matrixL();
      std::vector<Eigen::Vector2d> p;
      for (int i = 0; i <= kOutlineSamples; ++i) {
        const double a = 2 * M_PI * i / kOutlineSamples;
        p.push_back(c + L * Eigen::Vector2d(std::cos(a), std::sin(a)));
      }
      out.push_back(p);
      break;
    }
    case WrapShape::kTorus:
      project(WrapCircleS(s.outer_radius + s.inner_radius, 0.0));
      project(WrapCircleS(s.outer_radius - s.inner_radius, 0.0));
      project(WrapCircleS(s.outer_radius, s.inner_radius));
      project(WrapCircleS(s.outer_radius, -s.inner_radius));
      break;
  }
  return out;
}

Geometry Collect(const Model& model, const Eigen::VectorXd& q, double axis_length,
                 const std::vector<std::string>& muscles, WrapMode wrap_mode) {
  Data ws(model);
  Geometry g;
  const LimbDescription& d = model.description();
  g.bones.push_back(PointPosition(model, ws, q, d.root_link, Eigen::Vector3d::Zero()));
  for (const JointSpec& j : d.joints) {
    Eigen::Vector3d p = PointPosition(model, ws, q, j.child_link, Eigen::Vector3d::Zero());
    if ((p - g.bones.back()).norm() > kSameCentre) g.bones.push_back(p);
    if (j.type == JointType::kFixed) continue;
    auto it = std::find_if(g.centres.begin(), g.centres.end(), [&](const Geometry::Centre& c) {
      return (c.p - p).norm() <= kSameCentre;
    });
    if (it == g.centres.end()) {
      g.centres.push_back({p, {j.name}});
    } else {
      it->joints.push_back(j.name);
    }
    // The axis is fixed in the joint frame, which is the child frame (URDF): map it to world.
    Eigen::Vector3d axis = PointPosition(model, ws, q, j.child_link, j.axis) - p;
    axis.normalize();
    g.axes.push_back({j.name,
                      j.type == JointType::kPrismatic,
                      {p - 0.5 * axis_length * axis, p + 0.5 * axis_length * axis}});
  }
  g.endpoint = EndpointPose(model, ws, q);
  if ((g.endpoint.translation() - g.bones.back()).norm() > kSameCentre)
    g.bones.push_back(g.endpoint.translation());
  g.transducer = TransducerRotation(model, ws, q);
  std::vector<int> drawn;  // all muscles, or the named ones in the model's order
  for (int m = 0; m < model.muscle_count(); ++m) {
    if (muscles.empty() ||
        std::find(muscles.begin(), muscles.end(), model.muscle(m).name) != muscles.end()) {
      drawn.push_back(m);
    }
  }
  for (const std::string& name : muscles) model.MuscleIndex(name);  // throws listing the muscles
  std::vector<char> shown(d.wrap_objects.size(), muscles.empty() ? 1 : 0);
  // The wrapped paths are the engine's (MuscleWrappedPath), of the model in the drawing's mode.
  std::optional<Model> in_mode;
  if (wrap_mode != d.wrap_mode) in_mode.emplace(ModelInWrapMode(model, wrap_mode));
  const Model& path_model = in_mode ? *in_mode : model;
  Data path_ws(path_model);
  for (int m : drawn) {
    Geometry::Muscle mu{model.muscle(m).name, {}, MusclePathPoints(model, ws, q, m), {}};
    const MuscleSpec& spec = model.muscle(m);
    if (spec.wraps.empty()) {
      mu.points = mu.path_points;
      g.muscles.push_back(mu);
      continue;
    }
    const WrappedPath path = MuscleWrappedPath(path_model, path_ws, q, m);
    std::vector<size_t> objects;  // per wrap of the muscle, its index in d.wrap_objects
    for (const PathWrapSpec& w : spec.wraps) {
      const auto it = std::find_if(d.wrap_objects.begin(), d.wrap_objects.end(),
                                   [&](const WrapObjectSpec& o) { return o.name == w.object; });
      objects.push_back(static_cast<size_t>(it - d.wrap_objects.begin()));  // (Model checked it)
      shown[objects.back()] = 1;
    }
    for (size_t e = 0; e < path.elements.size(); ++e) {
      const WrappedPath::Element& el = path.elements[e];
      mu.points.push_back(el.position);
      if (el.wrap < 0 || el.end != 0) continue;
      const WrappedPath::Wrap& w = path.wraps[static_cast<size_t>(el.wrap)];
      const WrapObjectSpec& object = d.wrap_objects[objects[static_cast<size_t>(el.wrap)]];
      const Eigen::Isometry3d X_W_S = WrapObjectPose(model, ws, q, object);
      Geometry::Muscle::Arc arc{object.name, {}};
      for (const Eigen::Vector3d& p_S :
           SampleWrapArc(WrapSurface::From(object), w.r1_S, w.r2_S, w.arc_length, kArcSamples)) {
        arc.points.push_back(X_W_S * p_S);
      }
      // The ends are ComputeWrappedPath's tangent points themselves.
      arc.points.front() = w.r1;
      arc.points.back() = w.r2;
      mu.points.insert(mu.points.end(), arc.points.begin() + 1, arc.points.end() - 1);
      mu.arcs.push_back(arc);
    }
    g.muscles.push_back(mu);
  }
  for (size_t o = 0; o < d.wrap_objects.size(); ++o) {
    if (!shown[o]) continue;
    const WrapObjectSpec& spec = d.wrap_objects[o];
    g.surfaces.push_back({spec.name, spec.shape, spec.active, WrapSurface::From(spec),
                          WrapObjectPose(model, ws, q, spec)});
  }
  return g;
}

// A view maps world to screen: two world axes (right, up) and a scale.
struct View {
  std::string name;          // "top" / "side"
  int right, up;             // world axis indices
  double x0, y0;             // screen position of the view's top-left corner (inside padding)
  Eigen::Vector2d min, max;  // world bounds along (right, up)
  double scale;              // px per m
  Eigen::Vector2d Screen(const Eigen::Vector3d& p) const {
    return {x0 + (p[right] - min.x()) * scale, y0 + (max.y() - p[up]) * scale};
  }
};

double NiceScaleBar(double max_m) {
  double best = 0.001;
  for (double mm : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0}) {
    if (mm * 1e-3 <= max_m) best = mm * 1e-3;
  }
  return best;
}

const char* kAxisName[3] = {"x", "y", "z"};

// Text boxes for placing labels without overlap. A label of n characters at font size f (px)
// is taken as n * kLabelCharWidth * f wide (wider than the average sans-serif glyph, 0.5-0.55 em)
// and from kLabelAscent * f above to kLabelDescent * f below its baseline.
constexpr double kLabelCharWidth = 0.62;
constexpr double kLabelAscent = 0.85;
constexpr double kLabelDescent = 0.25;
constexpr double kLabelGap = 1.0;  // px kept free around every label

struct Box {
  double x0, y0, x1, y1;
  bool Overlaps(const Box& o) const {
    return x0 < o.x1 + kLabelGap && o.x0 < x1 + kLabelGap && y0 < o.y1 + kLabelGap &&
           o.y0 < y1 + kLabelGap;
  }
};

// Characters of UTF-8 text (continuation bytes are not counted).
size_t Characters(const std::string& text) {
  size_t n = 0;
  for (unsigned char c : text) n += (c & 0xC0) != 0x80;
  return n;
}

Box TextBox(double x, double y, const std::string& text, double size) {
  return {x, y - kLabelAscent * size,
          x + kLabelCharWidth * size * static_cast<double>(Characters(text)),
          y + kLabelDescent * size};
}

// Labels of one view: each is put at the first of its candidate positions (baseline, start
// anchor) whose box stays inside the view and overlaps no label placed before; a label with no
// free position is left out (and listed by the caller).
class LabelPlacer {
 public:
  explicit LabelPlacer(const Box& area) : area_(area) {}
  /// Reserve a box that is drawn whatever happens (e.g. the endpoint frame's axis letters).
  void Reserve(const Box& b) { placed_.push_back(b); }
  /// The index of the first free candidate (now taken), or -1.
  int Place(const std::string& text, double size, const std::vector<Eigen::Vector2d>& candidates) {
    for (size_t i = 0; i < candidates.size(); ++i) {
      const Box b = TextBox(candidates[i].x(), candidates[i].y(), text, size);
      if (b.x0 < area_.x0 || b.x1 > area_.x1 || b.y0 < area_.y0 || b.y1 > area_.y1) continue;
      bool free = true;
      for (const Box& p : placed_) free = free && !b.Overlaps(p);
      if (!free) continue;
      placed_.push_back(b);
      return static_cast<int>(i);
    }
    return -1;
  }

 private:
  Box area_;
  std::vector<Box> placed_;
};

// Points at fractions of a polyline's length (screen coordinates).
Eigen::Vector2d AlongPolyline(const std::vector<Eigen::Vector2d>& p, double fraction) {
  double total = 0;
  for (size_t i = 1; i < p.size(); ++i) total += (p[i] - p[i - 1]).norm();
  double left = fraction * total;
  for (size_t i = 1; i < p.size(); ++i) {
    const double d = (p[i] - p[i - 1]).norm();
    if (left <= d && d > 0) return p[i - 1] + (p[i] - p[i - 1]) * (left / d);
    left -= d;
  }
  return p.back();
}

// Candidate label positions around a point: right-above, right-below, left-above, left-below.
void AddAround(std::vector<Eigen::Vector2d>& out, const Eigen::Vector2d& p, double width, double dx,
               double above, double below) {
  out.push_back({p.x() + dx, p.y() - above});
  out.push_back({p.x() + dx, p.y() + below});
  out.push_back({p.x() - dx - width, p.y() - above});
  out.push_back({p.x() - dx - width, p.y() + below});
}

}  // namespace

std::string LimbStickFigureSvg(const Model& model, const Eigen::VectorXd& q,
                               const LimbDrawingOptions& options) {
  ValidatePosture(model, q);
  if (!(options.view_px > 0))
    throw Error("draw: view width must be > 0 px, got " + util::FormatNumber(options.view_px));
  if (!std::isfinite(options.axis_length)) throw Error("draw: axis length must be finite");
  const double axis_length =
      options.axis_length > 0 ? options.axis_length : kAxisFraction * model.chain_length();
  const Geometry g = Collect(model, q, axis_length, options.muscles, options.wrap_mode);

  // Everything that must fit in the views.
  std::vector<Eigen::Vector3d> all = g.bones;
  for (const auto& a : g.axes) {
    all.push_back(a.s.a);
    all.push_back(a.s.b);
  }
  for (const auto& m : g.muscles) all.insert(all.end(), m.points.begin(), m.points.end());
  for (const auto& w : g.surfaces) {
    // Its bounding box in world (the outline lies inside it).
    Eigen::Vector3d half = Eigen::Vector3d::Zero();
    switch (w.shape) {
      case WrapShape::kCylinder:
        half << w.surface.radius, w.surface.radius, 0.5 * w.surface.length;
        break;
      case WrapShape::kSphere: half.setConstant(w.surface.radius); break;
      case WrapShape::kEllipsoid: half = w.surface.radii; break;
      case WrapShape::kTorus:
        half << w.surface.outer_radius + w.surface.inner_radius,
            w.surface.outer_radius + w.surface.inner_radius, w.surface.inner_radius;
        break;
    }
    const Eigen::Vector3d extent = w.X_W_S.linear().cwiseAbs() * half;
    all.push_back(w.X_W_S.translation() - extent);
    all.push_back(w.X_W_S.translation() + extent);
  }
  for (int k = 0; k < 3; ++k) {
    all.push_back(g.endpoint.translation() + axis_length * g.endpoint.linear().col(k));
    all.push_back(g.endpoint.translation() + axis_length * g.transducer.col(k));
  }
  View views[2] = {{"top", 0, 1, 0, 0, {}, {}, 0}, {"side", 0, 2, 0, 0, {}, {}, 0}};
  double scale = 1e300;
  const double inner = options.view_px - 2 * kPad;
  for (View& v : views) {
    v.min = Eigen::Vector2d::Constant(1e300);
    v.max = Eigen::Vector2d::Constant(-1e300);
    for (const Eigen::Vector3d& p : all) {
      v.min = v.min.cwiseMin(Eigen::Vector2d(p[v.right], p[v.up]));
      v.max = v.max.cwiseMax(Eigen::Vector2d(p[v.right], p[v.up]));
    }
    const double range = std::max({v.max.x() - v.min.x(), v.max.y() - v.min.y(), 1e-6});
    scale = std::min(scale, inner / range);
  }
  double view_height = 0;
  for (View& v : views) {
    v.scale = scale;
    view_height = std::max(view_height, (v.max.y() - v.min.y()) * scale);
  }
  const double width = 2 * options.view_px;
  // A second subtitle line says how wraps are drawn.
  const double banner = kBannerLines + (g.surfaces.empty() ? 0.0 : kSubtitleLine);
  const double height = banner + kViewTitle + view_height + 2 * kPad + kFooter;
  const std::string title =
      options.title.empty() ? model.name() + " at " + FormatPosture(model, q) : options.title;

  plots::SvgWriter svg(width, height, title);
  svg.Text(12, 20, title, 14, "start", {{"class", "title"}, {"font-weight", "bold"}});
  svg.Text(12, 36,
           "Joint centres (circles) and axes (orange segments, dashed = prismatic), bones (grey), "
           "muscle paths (red), "
           "endpoint frame x y z (green, blue, red).",
           10, "start", {{"class", "subtitle"}});
  if (!g.surfaces.empty()) {
    svg.Text(12, 36 + kSubtitleLine,
             std::string("Wrap surfaces (blue; dashed = inactive, never wraps), paths wrapped over "
                         "them (") +
                 WrapModeName(options.wrap_mode) + " mode): tangent points white, arcs dark red.",
             10, "start", {{"class", "subtitle"}});
  }
  for (int i = 0; i < 2; ++i) {
    View& v = views[i];
    v.x0 = options.view_px * i + kPad;
    v.y0 = banner + kViewTitle + kPad;
    svg.Open("g", {{"class", "view"},
                   {"data-view", v.name},
                   {"data-right", kAxisName[v.right]},
                   {"data-up", kAxisName[v.up]},
                   {"data-px-per-m", plots::Exact(scale)},
                   {"data-origin-x", Num(v.Screen(Eigen::Vector3d::Zero()).x())},
                   {"data-origin-y", Num(v.Screen(Eigen::Vector3d::Zero()).y())}});
    svg.Element("rect", {{"x", Num(options.view_px * i + 4)},
                         {"y", Num(banner)},
                         {"width", Num(options.view_px - 8)},
                         {"height", Num(height - banner - 4)},
                         {"fill", "none"},
                         {"stroke", "#dddddd"}});
    svg.Text(options.view_px * i + 12, banner + 14,
             i == 0 ? "Top view (x right, y up; looking down -z)"
                    : "Side view (x right, z up; looking along +y)",
             12, "start", {{"class", "view-title"}, {"font-weight", "bold"}});
    // Bones.
    std::string points;
    for (const Eigen::Vector3d& p : g.bones) {
      Eigen::Vector2d s = v.Screen(p);
      points += Num(s.x()) + "," + Num(s.y()) + " ";
    }
    svg.Element("polyline", {{"class", "bones"},
                             {"points", points},
                             {"fill", "none"},
                             {"stroke", "#707070"},
                             {"stroke-width", "4"},
                             {"stroke-linejoin", "round"},
                             {"stroke-linecap", "round"}});
    // Joint axes.
    for (const auto& a : g.axes) {
      Eigen::Vector2d s0 = v.Screen(a.s.a), s1 = v.Screen(a.s.b);
      plots::Attributes extra = {{"class", "joint-axis"}, {"data-joint", a.joint}};
      if (a.prismatic) extra.push_back({"stroke-dasharray", "4,2"});
      svg.Line(s0.x(), s0.y(), s1.x(), s1.y(), "#e08000", 1.6, extra);
    }
    // Wrap surfaces: an outline per shape (WrapOutline); inactive objects dashed, unfilled.
    for (const auto& w : g.surfaces) {
      std::string d;
      for (const auto& line : WrapOutline(w.surface, w.X_W_S, v.right, v.up)) {
        for (size_t k = 0; k < line.size(); ++k) {
          const Eigen::Vector3d p3 = Eigen::Vector3d::Unit(v.right) * line[k].x() +
                                     Eigen::Vector3d::Unit(v.up) * line[k].y();
          const Eigen::Vector2d s = v.Screen(p3);
          d += (k == 0 ? "M" : "L") + Num(s.x()) + "," + Num(s.y()) + " ";
        }
      }
      plots::Attributes a = {{"class", "wrap-surface"},
                             {"data-wrap", w.name},
                             {"data-shape", WrapShapeName(w.shape)},
                             {"data-active", w.active ? "true" : "false"},
                             {"d", d},
                             {"fill", w.active ? "#2a6fb0" : "none"},
                             {"fill-opacity", "0.08"},
                             {"stroke", w.active ? "#2a6fb0" : "#8aa6c0"},
                             {"stroke-width", "1"}};
      if (!w.active) a.push_back({"stroke-dasharray", "3,2"});
      svg.Element("path", a);
    }
    // Muscles: the path through its points, tangent points and arcs (wrapped muscles).
    for (const auto& m : g.muscles) {
      std::string mp;
      for (const Eigen::Vector3d& p : m.points) {
        Eigen::Vector2d s = v.Screen(p);
        mp += Num(s.x()) + "," + Num(s.y()) + " ";
      }
      svg.Element("polyline", {{"class", "muscle"},
                               {"data-muscle", m.name},
                               {"data-wrapped", m.arcs.empty() ? "false" : "true"},
                               {"points", mp},
                               {"fill", "none"},
                               {"stroke", "#c0102a"},
                               {"stroke-width", "1.8"}});
      for (const Eigen::Vector3d& p : m.path_points) {
        Eigen::Vector2d s = v.Screen(p);
        svg.Element("circle", {{"class", "muscle-point"},
                               {"cx", Num(s.x())},
                               {"cy", Num(s.y())},
                               {"r", "2.5"},
                               {"fill", "#c0102a"}});
      }
      for (const auto& arc : m.arcs) {
        // The arc again, over the path, with its world coordinates (m) along the view's axes
        // in full precision (data-arc-m: "right,up ..."), and its two tangent points.
        std::string px, world;
        for (const Eigen::Vector3d& p : arc.points) {
          const Eigen::Vector2d s = v.Screen(p);
          px += Num(s.x()) + "," + Num(s.y()) + " ";
          world += plots::Exact(p[v.right]) + "," + plots::Exact(p[v.up]) + " ";
        }
        svg.Element("polyline", {{"class", "wrap-arc"},
                                 {"data-muscle", m.name},
                                 {"data-wrap", arc.wrap},
                                 {"data-arc-m", world},
                                 {"points", px},
                                 {"fill", "none"},
                                 {"stroke", "#7a0a1c"},
                                 {"stroke-width", "2.4"}});
        for (int end = 0; end < 2; ++end) {
          const Eigen::Vector3d& p = end == 0 ? arc.points.front() : arc.points.back();
          const Eigen::Vector2d s = v.Screen(p);
          svg.Element("circle", {{"class", "tangent-point"},
                                 {"data-muscle", m.name},
                                 {"data-wrap", arc.wrap},
                                 {"data-end", end == 0 ? "r1" : "r2"},
                                 {"data-right-m", plots::Exact(p[v.right])},
                                 {"data-up-m", plots::Exact(p[v.up])},
                                 {"cx", Num(s.x())},
                                 {"cy", Num(s.y())},
                                 {"r", "2"},
                                 {"fill", "white"},
                                 {"stroke", "#7a0a1c"},
                                 {"stroke-width", "1"}});
        }
      }
    }
    // Joint centres.
    for (const auto& c : g.centres) {
      Eigen::Vector2d s = v.Screen(c.p);
      svg.Element("circle", {{"class", "joint-centre"},
                             {"data-joints", util::Join(c.joints, " ")},
                             {"cx", Num(s.x())},
                             {"cy", Num(s.y())},
                             {"r", "4"},
                             {"fill", "white"},
                             {"stroke", "black"},
                             {"stroke-width", "1.2"}});
    }
    // Endpoint frame, and the transducer axes when they differ.
    const Box area{options.view_px * i + 6, banner + kViewTitle + 2, options.view_px * (i + 1) - 6,
                   height - kFooter};
    LabelPlacer labels(area);
    std::vector<std::string> left_out;
    // A label at the first free candidate (LabelPlacer); `anchors[k]` is what candidate k labels,
    // and a label put further than kLeaderDistance from it gets a thin leader line to it.
    auto place = [&](const std::string& text, double size, const std::vector<Eigen::Vector2d>& at,
                     const std::vector<Eigen::Vector2d>& anchors, const std::string& colour,
                     plots::Attributes attributes) {
      const int k = labels.Place(text, size, at);
      if (k < 0) {
        left_out.push_back(text);
        return;
      }
      const Eigen::Vector2d p = at[static_cast<size_t>(k)];
      const Eigen::Vector2d anchor = anchors[static_cast<size_t>(k)];
      const Box b = TextBox(p.x(), p.y(), text, size);
      const Eigen::Vector2d nearest(std::clamp(anchor.x(), b.x0, b.x1),
                                    std::clamp(anchor.y(), b.y0, b.y1));
      constexpr double kLeaderDistance = 16;  // px; nearer labels are read as their point's
      if ((nearest - anchor).norm() > kLeaderDistance) {
        svg.Line(anchor.x(), anchor.y(), nearest.x(), nearest.y(), colour, 0.5,
                 {{"class", "label-leader"}});
      }
      attributes.push_back({"fill", colour});
      svg.Text(p.x(), p.y(), text, size, "start", attributes);
    };
    // Candidates around `p`: right-above, right-below, left-above, left-below at `dx`, then
    // (far = true) stacked further up and down the view, 12 px apart, with a leader line.
    auto around = [&](std::vector<Eigen::Vector2d>& at, std::vector<Eigen::Vector2d>& anchors,
                      const Eigen::Vector2d& p, double width, double dx, double above, double below,
                      bool far) {
      AddAround(at, p, width, dx, above, below);
      if (far) {
        for (double step = 12; step < area.y1 - area.y0; step += 12) {
          AddAround(at, p, width, dx, above + step, below + step);
        }
      }
      anchors.resize(at.size(), p);
    };
    const Eigen::Vector3d e = g.endpoint.translation();
    const bool transducer_differs = !g.transducer.isApprox(g.endpoint.linear(), 1e-9);
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector2d s0 = v.Screen(e), s1 = v.Screen(e + axis_length * g.endpoint.linear().col(k));
      svg.Line(s0.x(), s0.y(), s1.x(), s1.y(), kAxisColors[k], 2.0,
               {{"class", "endpoint-axis"}, {"data-axis", kAxisName[k]}});
      std::vector<Eigen::Vector2d> at, anchors;
      around(at, anchors, s1, TextBox(0, 0, kAxisName[k], 10).x1, 3, 2, 9, false);
      place(kAxisName[k], 10, at, anchors, kAxisColors[k], {{"class", "axis-label"}});
      if (transducer_differs) {
        Eigen::Vector2d t1 = v.Screen(e + axis_length * g.transducer.col(k));
        svg.Line(s0.x(), s0.y(), t1.x(), t1.y(), kAxisColors[k], 1.2,
                 {{"class", "transducer-axis"},
                  {"data-axis", kAxisName[k]},
                  {"stroke-dasharray", "3,2"}});
        const std::string name = std::string("T") + kAxisName[k];
        at.clear();
        anchors.clear();
        around(at, anchors, t1, TextBox(0, 0, name, 9).x1, 3, 2, 9, false);
        place(name, 9, at, anchors, kAxisColors[k], {{"class", "axis-label"}});
      }
    }
    // Labels, most important first, each where it overlaps no other (LabelPlacer).
    {
      std::vector<Eigen::Vector2d> at, anchors;
      around(at, anchors, v.Screen(e), TextBox(0, 0, "endpoint", 9).x1, 6, 6, 14, true);
      place("endpoint", 9, at, anchors, "black", {{"class", "endpoint-label"}});
    }
    for (const auto& c : g.centres) {
      // A centre of many joints (an OpenSim knee's translations and rotations): its first joint
      // and how many more, when the list would take more than half the view's width (the full
      // list is the circle's data-joints).
      std::string text = util::Join(c.joints, ", ");
      if (TextBox(0, 0, text, 9).x1 > 0.5 * (area.x1 - area.x0) && c.joints.size() > 1) {
        text = c.joints.front() + " +" + std::to_string(c.joints.size() - 1) + " joints";
      }
      std::vector<Eigen::Vector2d> at, anchors;
      around(at, anchors, v.Screen(c.p), TextBox(0, 0, text, 9).x1, 7, 6, 12, true);
      place(text, 9, at, anchors, "black", {{"class", "joint-label"}});
    }
    for (const auto& m : g.muscles) {
      std::vector<Eigen::Vector2d> screen;
      for (const Eigen::Vector3d& p : m.points) screen.push_back(v.Screen(p));
      std::vector<Eigen::Vector2d> at, anchors;
      const double w = TextBox(0, 0, m.name, 10).x1;
      const std::vector<double> fractions = {0.5, 0.35, 0.65, 0.2, 0.8, 0.1, 0.9, 0.0, 1.0};
      for (double f : fractions) around(at, anchors, AlongPolyline(screen, f), w, 4, 4, 12, false);
      for (double f : fractions) around(at, anchors, AlongPolyline(screen, f), w, 4, 4, 12, true);
      place(m.name, 10, at, anchors, "#c0102a",
            {{"class", "muscle-label"}, {"data-muscle", m.name}});
    }
    if (!left_out.empty()) {
      // Counted under the scale bar; the names are in the note's data-left-out.
      svg.Text(options.view_px * i + 14, height - 4,
               std::to_string(left_out.size()) + " label" + (left_out.size() == 1 ? "" : "s") +
                   " left out where they would overlap (draw fewer muscles with --muscle)",
               9, "start", {{"class", "label-note"}, {"data-left-out", util::Join(left_out, ";")}});
    }
    // Scale bar.
    const double bar_m = NiceScaleBar(0.3 * inner / scale);
    const double bar_y = height - 18;
    const double bx = options.view_px * i + 14;
    svg.Line(bx, bar_y, bx + bar_m * scale, bar_y, "black", 2,
             {{"class", "scale-bar"}, {"data-value-m", plots::Exact(bar_m)}});
    svg.Text(bx + bar_m * scale + 6, bar_y + 4, util::FormatNumber(bar_m * 1e3, 3) + " mm", 10,
             "start", {{"class", "scale-label"}});
    svg.Close();
  }
  return svg.Finish();
}

}  // namespace isowrench
