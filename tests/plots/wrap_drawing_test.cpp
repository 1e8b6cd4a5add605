// Tests of the wrap drawing (LimbStickFigureSvg with wraps) and the wrap-mode comparison
// (include/isowrench/wrap_report.hpp) on tests/data/planar_2r_wrap.urdf, whose geometry is
// re-derived here by hand: shoulder and elbow turn about world z, the upper link is 0.30 m, a
// cylinder of radius 30 mm and length 100 mm about the elbow axis sits on the upper link, the
// extensor runs from (0.15, -0.03, 0.02) m on the upper link to (0.05, -0.03, -0.01) m on the
// forearm over it, and the flexor lists an inactive sphere.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tinyxml2.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/io.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/wrap.hpp"
#include "isowrench/wrap_report.hpp"
#include "svg_test_utils.hpp"

namespace isowrench_test {
namespace {

using isowrench::WrapMode;
using V3 = Eigen::Vector3d;

constexpr double kCylinderRadius = 0.03;
constexpr double kCylinderHalfLength = 0.05;
const V3 kElbowInUpper(0.30, 0, 0);

isowrench::LimbDescription WrapFixture() {
  return isowrench::ReadUrdfFile(std::string(ISOWRENCH_TEST_DATA_DIR) + "/planar_2r_wrap.urdf");
}

Eigen::Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, V3::UnitZ()).toRotationMatrix(); }

// The extensor's path input at (shoulder q1, elbow q2), from the geometry above alone.
isowrench::WrapPathInput ExtensorByHand(double q1, double q2) {
  isowrench::WrapPathInput in;
  const V3 elbow = Rz(q1) * kElbowInUpper;
  in.points = {Rz(q1) * V3(0.15, -0.03, 0.02), elbow + Rz(q1 + q2) * V3(0.05, -0.03, -0.01)};
  in.active = {1, 1};
  isowrench::WrapPathWrap w;
  w.surface.shape = isowrench::WrapShape::kCylinder;
  w.surface.radius = kCylinderRadius;
  w.surface.length = 2 * kCylinderHalfLength;
  w.X_W_S.linear() = Rz(q1);
  w.X_W_S.translation() = elbow;
  w.first = 0;
  w.last = 1;
  in.wraps = {w};
  return in;
}

// Moment arms by hand: Q_c = -sum pull . (z x (x - o_c)) over the elements joint c moves. The
// shoulder (o = 0) moves everything; the elbow moves only the insertion (the tangent points are
// fixed on the upper link with the cylinder).
Eigen::Vector2d ArmsByHand(double q1, const isowrench::WrapPathInput& in,
                           const isowrench::WrappedPath& p) {
  const V3 z = V3::UnitZ(), elbow = Rz(q1) * kElbowInUpper;
  Eigen::Vector2d arm = Eigen::Vector2d::Zero();
  auto add = [&](const V3& pull, const V3& x, bool on_forearm) {
    arm[0] -= pull.dot(z.cross(x));
    if (on_forearm) arm[1] -= pull.dot(z.cross(x - elbow));
  };
  add(p.point_pull[0], in.points[0], false);
  add(p.point_pull[1], in.points[1], true);
  if (p.wraps[0].wrapped) {
    add(p.wraps[0].pull_r1, p.wraps[0].r1, false);
    add(p.wraps[0].pull_r2, p.wraps[0].r2, false);
  }
  return arm;
}

struct WrapView {
  const tinyxml2::XMLElement* g = nullptr;
  int right = 0, up = 0;
  double scale = 0;
  Eigen::Vector2d origin;
  Eigen::Vector2d Screen(const V3& p) const {
    return origin + scale * Eigen::Vector2d(p[right], -p[up]);
  }
};

WrapView ReadWrapView(const tinyxml2::XMLElement* root, const std::string& name) {
  for (const auto* g : ByClass(root, "view")) {
    if (name != g->Attribute("data-view")) continue;
    auto axis = [](const char* a) { return a[0] - 'x'; };
    return {g,
            axis(g->Attribute("data-right")),
            axis(g->Attribute("data-up")),
            Num(g, "data-px-per-m"),
            {Num(g, "data-origin-x"), Num(g, "data-origin-y")}};
  }
  ADD_FAILURE() << "no view " << name;
  return {};
}

std::vector<const tinyxml2::XMLElement*> Of(const std::vector<const tinyxml2::XMLElement*>& all,
                                            const char* attribute, const std::string& value) {
  std::vector<const tinyxml2::XMLElement*> out;
  for (const auto* e : all) {
    if (e->Attribute(attribute) && value == e->Attribute(attribute)) out.push_back(e);
  }
  return out;
}

// "a,b c,d ..." as pairs.
std::vector<Eigen::Vector2d> Pairs(const char* text) {
  std::vector<Eigen::Vector2d> out;
  std::istringstream in(text ? text : "");
  for (std::string item; in >> item;) {
    const size_t comma = item.find(',');
    out.emplace_back(std::stod(item.substr(0, comma)), std::stod(item.substr(comma + 1)));
  }
  return out;
}

std::string Draw(const isowrench::Model& model, const Eigen::VectorXd& q, WrapMode mode,
                 tinyxml2::XMLDocument& doc) {
  isowrench::LimbDrawingOptions options;
  options.wrap_mode = mode;
  const std::string svg = isowrench::LimbStickFigureSvg(model, q, options);
  EXPECT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS) << doc.ErrorStr();
  return svg;
}

TEST(WrapDrawing, TangentPointsAreComputeWrappedPathsInEachViewAndMode) {
  const isowrench::Model model(WrapFixture());
  const Eigen::VectorXd q = model.nominal_posture();  // shoulder 30°, elbow 60°
  ASSERT_NEAR(q[0], M_PI / 6, 1e-12);
  ASSERT_NEAR(q[1], M_PI / 3, 1e-12);
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    SCOPED_TRACE(isowrench::WrapModeName(mode));
    isowrench::WrappedPath expected;
    isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1]), mode, expected);
    ASSERT_TRUE(expected.wraps[0].wrapped);
    tinyxml2::XMLDocument doc;
    Draw(model, q, mode, doc);
    for (const char* name : {"top", "side"}) {
      SCOPED_TRACE(name);
      const WrapView v = ReadWrapView(doc.RootElement(), name);
      const auto tangents = Of(ByClass(v.g, "tangent-point"), "data-muscle", "extensor");
      ASSERT_EQ(tangents.size(), 2u);
      for (const auto* t : tangents) {
        const bool r1 = std::string(t->Attribute("data-end")) == "r1";
        const V3& p = r1 ? expected.wraps[0].r1 : expected.wraps[0].r2;
        EXPECT_NEAR(Num(t, "data-right-m"), p[v.right], 1e-9);
        EXPECT_NEAR(Num(t, "data-up-m"), p[v.up], 1e-9);
        EXPECT_NEAR((Eigen::Vector2d(Num(t, "cx"), Num(t, "cy")) - v.Screen(p)).norm(), 0, 2e-3);
      }
      // The muscle's polyline is wrapped and passes through both tangent points.
      const auto muscle = Of(ByClass(v.g, "muscle"), "data-muscle", "extensor");
      ASSERT_EQ(muscle.size(), 1u);
      EXPECT_STREQ(muscle[0]->Attribute("data-wrapped"), "true");
      const std::vector<Eigen::Vector2d> px = Pairs(muscle[0]->Attribute("points"));
      for (const V3& p : {expected.wraps[0].r1, expected.wraps[0].r2}) {
        double nearest = 1e300;
        for (const Eigen::Vector2d& s : px) nearest = std::min(nearest, (s - v.Screen(p)).norm());
        EXPECT_LT(nearest, 2e-3);
      }
    }
  }
}

TEST(WrapDrawing, ArcLiesOnTheCylinderAndHasTheWrapsArcLength) {
  const isowrench::Model model(WrapFixture());
  const Eigen::VectorXd q = model.nominal_posture();
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    SCOPED_TRACE(isowrench::WrapModeName(mode));
    isowrench::WrappedPath expected;
    isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1]), mode, expected);
    tinyxml2::XMLDocument doc;
    Draw(model, q, mode, doc);
    const WrapView top = ReadWrapView(doc.RootElement(), "top");
    const WrapView side = ReadWrapView(doc.RootElement(), "side");
    const auto top_arc = ByClass(top.g, "wrap-arc");
    const auto side_arc = ByClass(side.g, "wrap-arc");
    ASSERT_EQ(top_arc.size(), 1u);
    ASSERT_EQ(side_arc.size(), 1u);
    EXPECT_STREQ(top_arc[0]->Attribute("data-wrap"), "elbow_cyl");
    // World (x, y) from the top view and (x, z) from the side view: one 3-D point per sample.
    const auto xy = Pairs(top_arc[0]->Attribute("data-arc-m"));
    const auto xz = Pairs(side_arc[0]->Attribute("data-arc-m"));
    ASSERT_EQ(xy.size(), xz.size());
    ASSERT_GE(xy.size(), 10u);
    const V3 elbow = Rz(q[0]) * kElbowInUpper;
    double polyline = 0;
    for (size_t i = 0; i < xy.size(); ++i) {
      EXPECT_EQ(xy[i].x(), xz[i].x());
      const V3 p(xy[i].x(), xy[i].y(), xz[i].y());
      // The cylinder's axis is world z through the elbow.
      EXPECT_NEAR(Eigen::Vector2d(p.x() - elbow.x(), p.y() - elbow.y()).norm(), kCylinderRadius,
                  1e-9)
          << "sample " << i;
      EXPECT_LE(std::abs(p.z() - elbow.z()), kCylinderHalfLength);
      if (i > 0) {
        polyline += (p - V3(xy[i - 1].x(), xy[i - 1].y(), xz[i - 1].y())).norm();
      }
    }
    // The chords of a helix sampled finely are its length to well under 0.1 %; the arc goes the
    // way the path goes (the other way round would be about 2 pi R - arc longer).
    EXPECT_NEAR(polyline, expected.wraps[0].arc_length, 1e-3 * expected.wraps[0].arc_length);
    EXPECT_GT(expected.wraps[0].arc_length, 1e-3);
  }
}

TEST(WrapDrawing, InactiveWrapIsDashedAndNeverBendsThePath) {
  isowrench::LimbDescription d = WrapFixture();
  {
    const isowrench::Model model(d);
    tinyxml2::XMLDocument doc;
    Draw(model, model.nominal_posture(), WrapMode::kOpenSim, doc);
    for (const char* name : {"top", "side"}) {
      SCOPED_TRACE(name);
      const WrapView v = ReadWrapView(doc.RootElement(), name);
      const auto ball = Of(ByClass(v.g, "wrap-surface"), "data-wrap", "off_ball");
      ASSERT_EQ(ball.size(), 1u);
      EXPECT_STREQ(ball[0]->Attribute("data-active"), "false");
      EXPECT_STREQ(ball[0]->Attribute("data-shape"), "sphere");
      EXPECT_NE(ball[0]->Attribute("stroke-dasharray"), nullptr);
      EXPECT_STREQ(ball[0]->Attribute("fill"), "none");
      const auto cyl = Of(ByClass(v.g, "wrap-surface"), "data-wrap", "elbow_cyl");
      ASSERT_EQ(cyl.size(), 1u);
      EXPECT_EQ(cyl[0]->Attribute("stroke-dasharray"), nullptr);
      const auto flexor = Of(ByClass(v.g, "muscle"), "data-muscle", "flexor");
      ASSERT_EQ(flexor.size(), 1u);
      EXPECT_STREQ(flexor[0]->Attribute("data-wrapped"), "false");
      EXPECT_EQ(Pairs(flexor[0]->Attribute("points")).size(), 2u);  // origin, insertion
      EXPECT_TRUE(Of(ByClass(v.g, "wrap-arc"), "data-muscle", "flexor").empty());
      EXPECT_TRUE(Of(ByClass(v.g, "tangent-point"), "data-muscle", "flexor").empty());
    }
  }
  // The same sphere active: the flexor's straight line goes through it, so it wraps (the
  // fixture would catch a drawing that ignored `active`).
  for (isowrench::WrapObjectSpec& o : d.wrap_objects) o.active = true;
  const isowrench::Model model(d);
  tinyxml2::XMLDocument doc;
  Draw(model, model.nominal_posture(), WrapMode::kOpenSim, doc);
  const WrapView v = ReadWrapView(doc.RootElement(), "top");
  EXPECT_EQ(Of(ByClass(v.g, "wrap-arc"), "data-muscle", "flexor").size(), 1u);
  const auto ball = Of(ByClass(v.g, "wrap-surface"), "data-wrap", "off_ball");
  ASSERT_EQ(ball.size(), 1u);
  EXPECT_EQ(ball[0]->Attribute("stroke-dasharray"), nullptr);
}

// The points of an SVG path's data "Mx,y Lx,y ...".
std::vector<Eigen::Vector2d> PathPoints(const tinyxml2::XMLElement* e) {
  std::string d = e->Attribute("d");
  for (char& c : d) c = (c == 'M' || c == 'L') ? ' ' : c;
  return Pairs(d.c_str());
}

TEST(WrapDrawing, OutlinesAreTheSurfacesProjections) {
  const isowrench::Model model(WrapFixture());
  const Eigen::VectorXd q = model.nominal_posture();
  tinyxml2::XMLDocument doc;
  Draw(model, q, WrapMode::kOpenSim, doc);
  const V3 elbow = Rz(q[0]) * kElbowInUpper;
  const V3 ball = Rz(q[0]) * V3(0.27, 0.036, 0);
  constexpr double kPx = 2e-3;  // 3 decimals written
  // Top view, looking along the cylinder's axis: its end circles are one circle of radius R;
  // the sphere is a circle of its radius.
  const WrapView top = ReadWrapView(doc.RootElement(), "top");
  for (const auto& [name, centre, radius] : {std::make_tuple("elbow_cyl", elbow, kCylinderRadius),
                                             std::make_tuple("off_ball", ball, 0.006)}) {
    SCOPED_TRACE(name);
    const auto e = Of(ByClass(top.g, "wrap-surface"), "data-wrap", name);
    ASSERT_EQ(e.size(), 1u);
    const auto points = PathPoints(e[0]);
    ASSERT_GE(points.size(), 36u);
    for (const Eigen::Vector2d& p : points)
      EXPECT_NEAR((p - top.Screen(centre)).norm(), radius * top.scale, kPx);
  }
  // Side view, across the axis: the cylinder is the rectangle x in elbow.x +- R, z in +- L/2.
  const WrapView side = ReadWrapView(doc.RootElement(), "side");
  const auto cyl = Of(ByClass(side.g, "wrap-surface"), "data-wrap", "elbow_cyl");
  ASSERT_EQ(cyl.size(), 1u);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = -lo;
  for (const Eigen::Vector2d& p : PathPoints(cyl[0])) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector2d a = side.Screen(elbow + V3(-kCylinderRadius, 0, kCylinderHalfLength));
  const Eigen::Vector2d b = side.Screen(elbow + V3(kCylinderRadius, 0, -kCylinderHalfLength));
  EXPECT_NEAR((lo - a).norm(), 0, kPx);
  EXPECT_NEAR((hi - b).norm(), 0, kPx);
}

// The document parses as XML with an <svg> root, and every number in a geometry attribute
// (coordinates, point lists, path data) is finite.
void ExpectWellFormed(const std::string& svg) {
  tinyxml2::XMLDocument doc;
  ASSERT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS) << doc.ErrorStr();
  EXPECT_STREQ(doc.RootElement()->Name(), "svg");
  std::vector<std::string> attributes;
  AllAttributes(doc.RootElement(), &attributes);
  const std::set<std::string> geometry = {
      "cx",           "cy",        "r",     "x",      "y", "x1",
      "y1",           "x2",        "y2",    "points", "d", "data-arc-m",
      "data-right-m", "data-up-m", "width", "height"};
  int numbers = 0;
  for (const std::string& a : attributes) {
    const size_t eq = a.find('=');
    if (!geometry.count(a.substr(0, eq))) continue;
    std::string value = a.substr(eq + 1);
    for (char& c : value) c = (c == ',' || c == 'M' || c == 'L') ? ' ' : c;
    std::istringstream in(value);
    for (std::string token; in >> token; ++numbers) {
      char* end = nullptr;
      const double x = std::strtod(token.c_str(), &end);
      EXPECT_TRUE(*end == '\0' && std::isfinite(x)) << a;
    }
  }
  EXPECT_GT(numbers, 100);
}

TEST(WrapDrawing, SvgIsWellFormedForEveryShapeAndMode) {
  // wraps.osim (tests/opensim/data) holds a cylinder, a sphere, an ellipsoid and a torus.
  isowrench::OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  const isowrench::OpenSimImport import = isowrench::ImportOpenSimFile(
      std::string(ISOWRENCH_TEST_DATA_DIR) + "/../opensim/data/wraps.osim", options);
  const isowrench::Model model(import.description);
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    isowrench::LimbDrawingOptions drawing;
    drawing.wrap_mode = mode;
    const std::string svg = isowrench::LimbStickFigureSvg(model, model.nominal_posture(), drawing);
    ExpectWellFormed(svg);
    tinyxml2::XMLDocument doc;
    doc.Parse(svg.c_str());
    std::set<std::string> shapes;
    for (const auto* s : ByClass(doc.RootElement(), "wrap-surface"))
      shapes.insert(s->Attribute("data-shape"));
    EXPECT_EQ(shapes, (std::set<std::string>{"cylinder", "sphere", "ellipsoid", "torus"}));
  }
  const isowrench::Model fixture(WrapFixture());
  ExpectWellFormed(isowrench::LimbStickFigureSvg(fixture, fixture.nominal_posture()));
}

TEST(WrapDrawing, PublishedRatModelDrawsWellFormed) {
  // The published rat hindlimb is not part of the repository (no licence): skip without it.
  const std::string path = "/work/ext/RatHindlimb/models/osim/rat_hindlimb.osim";
  if (!std::ifstream(path).good()) GTEST_SKIP() << path << " is absent";
  isowrench::OpenSimImportOptions options;
  options.clamp_body = "pelvis_r";
  options.endpoint_body = "foot_r";
  const isowrench::Model model(isowrench::ImportOpenSimFile(path, options).description);
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    isowrench::LimbDrawingOptions drawing;
    drawing.wrap_mode = mode;
    const std::string svg = isowrench::LimbStickFigureSvg(model, model.nominal_posture(), drawing);
    ExpectWellFormed(svg);
    EXPECT_NE(svg.find("class=\"wrap-arc\""), std::string::npos);
  }
}

TEST(WrapModeComparison, EqualsBothModesRecomputedByHand) {
  const isowrench::Model model(WrapFixture());
  isowrench::Data data(model);
  const int extensor = model.MuscleIndex("extensor");
  for (double elbow_deg : {40.0, 60.0, 75.0}) {
    SCOPED_TRACE(elbow_deg);
    Eigen::VectorXd q = model.nominal_posture();
    q[1] = elbow_deg * M_PI / 180;
    const isowrench::WrapPathInput in = ExtensorByHand(q[0], q[1]);
    isowrench::WrappedPath os, ex;
    isowrench::ComputeWrappedPath(in, WrapMode::kOpenSim, os);
    isowrench::ComputeWrappedPath(in, WrapMode::kExact, ex);
    ASSERT_TRUE(os.wraps[0].wrapped);
    const Eigen::Vector2d arm_os = ArmsByHand(q[0], in, os), arm_ex = ArmsByHand(q[0], in, ex);
    // Exact mode: the moment arm is -dL/dq (central differences of the hand-built path).
    const double h = 1e-6;
    isowrench::WrappedPath plus, minus;
    isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1] + h), WrapMode::kExact, plus);
    isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1] - h), WrapMode::kExact, minus);
    EXPECT_NEAR(arm_ex[1], -(plus.length - minus.length) / (2 * h), 1e-8);

    const isowrench::WrapModeDifference d = isowrench::CompareWrapModes(model, data, q, extensor);
    EXPECT_EQ(d.muscle, extensor);
    EXPECT_NEAR(d.length_opensim, os.length, 1e-12);
    EXPECT_NEAR(d.length_exact, ex.length, 1e-12);
    EXPECT_NEAR(d.LengthDifference(), os.length - ex.length, 1e-12);
    ASSERT_EQ(d.moment_arm_opensim.size(), 2);
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(d.moment_arm_opensim[c], arm_os[c], 1e-12) << c;
      EXPECT_NEAR(d.moment_arm_exact[c], arm_ex[c], 1e-12) << c;
    }
    const Eigen::Vector2d diff = (arm_os - arm_ex).cwiseAbs();
    int worst = 0;
    EXPECT_NEAR(d.moment_arm_difference, diff.maxCoeff(&worst), 1e-12);
    EXPECT_EQ(d.coordinate, worst);
    EXPECT_EQ(d.wraps_engaged, 1);
    // The end points are at different heights along the axis: OpenSim's path is not the
    // shortest, so the modes differ (a comparison that printed 0 would be caught).
    EXPECT_GT(os.length - ex.length, 1e-7);
    EXPECT_GT(d.moment_arm_difference, 1e-6);
    EXPECT_NEAR(d.length_straight, (in.points[1] - in.points[0]).norm(), 1e-12);
  }
}

TEST(WrapModeComparison, SweepIsTheLargestOverItsPostures) {
  const isowrench::Model model(WrapFixture());
  isowrench::Data data(model);
  const Eigen::VectorXd q0 = model.nominal_posture();
  const int steps = 4;
  const isowrench::WrapModeSweep s =
      isowrench::SweepWrapModes(model, data, q0, model.MuscleIndex("extensor"), steps);
  // q0, then each coordinate over its URDF limits [-3.14, 3.14] rad.
  EXPECT_EQ(s.postures, 1 + 2 * steps);
  double worst_length =
      std::abs(isowrench::CompareWrapModes(model, data, q0, 0).LengthDifference());
  for (int c = 0; c < 2; ++c) {
    for (int k = 0; k < steps; ++k) {
      Eigen::VectorXd q = q0;
      q[c] = -3.14 + 6.28 * k / (steps - 1);
      isowrench::WrappedPath os, ex;
      isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1]), WrapMode::kOpenSim, os);
      isowrench::ComputeWrappedPath(ExtensorByHand(q[0], q[1]), WrapMode::kExact, ex);
      worst_length = std::max(worst_length, std::abs(os.length - ex.length));
    }
  }
  EXPECT_NEAR(s.max_length_difference, worst_length, 1e-12);
  EXPECT_THROW(isowrench::SweepWrapModes(model, data, q0, 0, 1), isowrench::Error);
}

// The reports' paths are the engine's: at each posture and in each mode, MuscleWrappedPath of
// the model in that mode (ModelInWrapMode) is ComputeWrappedPath of the hand-built input, and
// WrapObjectPose is the hand-built cylinder frame.
TEST(WrapModeComparison, EnginePathInEachModeMatchesTheHandGeometry) {
  const isowrench::Model model(WrapFixture());
  isowrench::Data data(model);
  const int extensor = model.MuscleIndex("extensor");
  for (const WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    const isowrench::Model in_mode = isowrench::ModelInWrapMode(model, mode);
    EXPECT_EQ(in_mode.description().wrap_mode, mode);
    isowrench::Data ws(in_mode);
    for (double elbow_deg : {20.0, 60.0, 75.0}) {
      SCOPED_TRACE(elbow_deg);
      Eigen::VectorXd q = model.nominal_posture();
      q[1] = elbow_deg * M_PI / 180;
      const isowrench::WrapPathInput hand = ExtensorByHand(q[0], q[1]);
      isowrench::WrappedPath expected;
      isowrench::ComputeWrappedPath(hand, mode, expected);
      const isowrench::WrappedPath path = isowrench::MuscleWrappedPath(in_mode, ws, q, extensor);
      EXPECT_NEAR(path.length, expected.length, 1e-12);
      ASSERT_EQ(path.elements.size(), expected.elements.size());
      for (size_t e = 0; e < path.elements.size(); ++e) {
        EXPECT_LT((path.elements[e].position - expected.elements[e].position).norm(), 1e-12) << e;
      }
      const isowrench::WrapObjectSpec& cylinder = model.description().wrap_objects[0];
      EXPECT_TRUE(
          isowrench::WrapObjectPose(model, data, q, cylinder).isApprox(hand.wraps[0].X_W_S, 1e-14));
    }
  }
  EXPECT_EQ(isowrench::WrappingMuscles(model), (std::vector<int>{0, 1}));
  EXPECT_EQ(isowrench::FormatWrapMm(1e-15), "0");
  EXPECT_EQ(isowrench::FormatWrapMm(0.00125), "1.25");
}

}  // namespace
}  // namespace isowrench_test
