// A muscle's wrapped path (ComputeWrappedPath): OpenSim's range, pass and order rules case by
// case, the moment arm from the pulls against differences of the length, length continuity where
// a wrap engages, and the description checks.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "isowrench/error.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {
namespace {

using V3 = Eigen::Vector3d;
using ::testing::HasSubstr;
constexpr double kPiPath = 3.14159265358979323846;

WrapPathWrap PathCylinder(double R, const V3& at, int first, int last,
                          const std::string& quadrant = "all") {
  WrapPathWrap w;
  w.surface.shape = WrapShape::kCylinder;
  w.surface.radius = R;
  w.surface.length = 1.0;
  w.surface.quadrant = WrapQuadrant::Parse(quadrant);
  w.X_W_S.translation() = at;
  w.first = first;
  w.last = last;
  return w;
}

WrapPathInput Points(std::initializer_list<V3> points) {
  WrapPathInput in;
  in.points = points;
  in.active.assign(in.points.size(), 1);
  return in;
}

double Straight(const WrapPathInput& in) {
  double l = 0;
  int previous = -1;
  for (int i = 0; i < static_cast<int>(in.points.size()); ++i) {
    if (!in.active[i]) continue;
    if (previous >= 0) l += (in.points[i] - in.points[previous]).norm();
    previous = i;
  }
  return l;
}

TEST(WrappedPathTest, RangeChoosesTheSegmentTheWrapActsOn) {
  // P0 -> P1 clear of the cylinder, P1 -> P2 through it.
  const V3 P0(-0.05, 0.05, 0), P1(0.03, 0.003, 0), P2(-0.03, -0.002, 0);
  WrappedPath out;
  for (int last : {3, -1}) {  // range "2 3" and "1 -1" (whole path): the crossing segment
    WrapPathInput in = Points({P0, P1, P2});
    in.wraps.push_back(PathCylinder(0.01, V3::Zero(), last == 3 ? 1 : 0, 2));
    ComputeWrappedPath(in, WrapMode::kOpenSim, out);
    ASSERT_TRUE(out.wraps[0].wrapped);
    ASSERT_EQ(out.elements.size(), 5u);
    EXPECT_EQ(out.elements[1].point, 1);
    EXPECT_EQ(out.elements[2].wrap, 0);
    EXPECT_EQ(out.elements[4].point, 2);
    EXPECT_GT(out.length, Straight(in));
  }
  // Range "1 2": only the clear segment: no wrap, the straight length.
  WrapPathInput in = Points({P0, P1, P2});
  in.wraps.push_back(PathCylinder(0.01, V3::Zero(), 0, 1));
  ComputeWrappedPath(in, WrapMode::kOpenSim, out);
  EXPECT_FALSE(out.wraps[0].wrapped);
  EXPECT_NEAR(out.length, Straight(in), 1e-15);
  EXPECT_EQ(out.elements.size(), 3u);
}

TEST(WrappedPathTest, InactiveRangeEndsMoveToTheNextActivePointAndAnEmptyRangeStopsTheWraps) {
  const V3 P0(0.05, 0.002, 0), P1(0.0, 0.05, 0), P2(-0.05, 0.0, 0);
  // P1 inactive: the segment P0 -> P2 crosses the cylinder; a range naming only P1.. P2 starts
  // at the next active point P2 and ends at P2: no segment, no wrap.
  WrapPathInput in = Points({P0, P1, P2});
  in.active[1] = 0;
  in.wraps.push_back(PathCylinder(0.01, V3::Zero(), 0, 2));
  WrappedPath out;
  ComputeWrappedPath(in, WrapMode::kOpenSim, out);
  EXPECT_TRUE(out.wraps[0].wrapped);
  in.wraps[0].first = 1;  // range "2 3": P1 inactive -> starts at P2
  ComputeWrappedPath(in, WrapMode::kOpenSim, out);
  EXPECT_FALSE(out.wraps[0].wrapped);
  // Range "2 2" with P2 inactive: no active point. OpenSim returns from applyWrapObjects: this
  // wrap and every wrap after it are not applied.
  in.wraps[0].first = in.wraps[0].last = 1;
  in.wraps.push_back(PathCylinder(0.01, V3::Zero(), 0, 2));
  ComputeWrappedPath(in, WrapMode::kOpenSim, out);
  EXPECT_FALSE(out.wraps[0].wrapped);
  EXPECT_FALSE(out.wraps[1].wrapped);
  EXPECT_TRUE(out.status & kWrapRangeEmpty);
  EXPECT_NEAR(out.length, Straight(in), 1e-15);
}

TEST(WrappedPathTest, MandatoryWrapTakesTheFirstCrossingSegment) {
  // Both segments cross the cylinder: OpenSim takes the first (an ill-conditioned case).
  const V3 P0(0.05, 0.001, 0), P1(-0.05, 0.002, 0), P2(0.05, 0.003, 0);
  WrapPathInput in = Points({P0, P1, P2});
  in.wraps.push_back(PathCylinder(0.01, V3::Zero(), 0, 2));
  WrappedPath out;
  ComputeWrappedPath(in, WrapMode::kOpenSim, out);
  ASSERT_TRUE(out.wraps[0].wrapped);
  EXPECT_EQ(out.wraps[0].action, WrapAction::kMandatoryWrap);
  EXPECT_EQ(out.elements[1].wrap, 0);  // between P0 and P1
  EXPECT_EQ(out.elements[3].point, 1);
}

TEST(WrappedPathTest, TwoPulleysGiveOpenSimsMomentArmAndEqualLengths) {
  // testGeometryPathWrapping.cpp "PathSpring with WrapCylinder": pulleys of r = 0.25 (0.05
  // long); the insertion at the origin of a body pinned at (-off, 0) about z, turned by q; the
  // origin at (-off, 0) on ground. Spring 1's pulley on ground at the origin, spring 2's on the
  // body's offset frame (at the pin, i.e. turning with the body). OpenSim: moment arm r,
  // equal lengths, for q = i pi / 20, i = 0 .. 9.
  const double r = 0.25;
  const double off = std::sqrt(2.0) * r - 0.05;
  for (int i = 0; i < 10; ++i) {
    const double q = i * kPiPath / 20;
    // The body frame: X_ground_body = [Rz(q) at the pin (0,0)] * [translation (off, 0)]^-1 ...
    // the joint's child frame is the body offset frame "bToj" = body translated by (-off, 0):
    // X_G_bToj = Rz(q) (pin at ground origin), X_G_body = X_G_bToj * X_bToj_body, with
    // X_body_bToj = translation(-off, 0, 0).
    Eigen::Isometry3d X_G_bToj = Eigen::Isometry3d::Identity();
    X_G_bToj.linear() = Eigen::AngleAxisd(q, V3::UnitZ()).toRotationMatrix();
    Eigen::Isometry3d X_body_bToj = Eigen::Isometry3d::Identity();
    X_body_bToj.translation() = V3(-off, 0, 0);
    const Eigen::Isometry3d X_G_body = X_G_bToj * X_body_bToj.inverse();
    const V3 origin(-off, 0, 0);
    const V3 insertion = X_G_body * V3::Zero();
    double lengths[2];
    for (int spring = 0; spring < 2; ++spring) {
      WrapPathInput in = Points({origin, insertion});
      WrapPathWrap w = PathCylinder(r, V3::Zero(), 0, 1);
      w.surface.length = 0.05;
      w.X_W_S = spring == 0 ? Eigen::Isometry3d::Identity() : X_G_bToj;
      in.wraps.push_back(w);
      WrappedPath out;
      ComputeWrappedPath(in, WrapMode::kOpenSim, out);
      lengths[spring] = out.length;
      // Moment arm: -sum pull . dx/dq; the insertion and (spring 2) the tangent points turn
      // with the body about the pin at the origin: dx/dq = z x x.
      double dL = out.point_pull[1].dot(V3::UnitZ().cross(insertion));
      if (spring == 1 && out.wraps[0].wrapped) {
        dL += out.wraps[0].pull_r1.dot(V3::UnitZ().cross(out.wraps[0].r1)) +
              out.wraps[0].pull_r2.dot(V3::UnitZ().cross(out.wraps[0].r2));
      }
      EXPECT_NEAR(-dL, r, 1e-12) << "q " << q << " spring " << spring + 1;
    }
    EXPECT_NEAR(lengths[0], lengths[1], 1e-12) << "q " << q;
  }
}

// Rigid motion by q of three bodies: P on A, the wrap object on B, N on C, each turning about
// its own axis through its own point. The moment arm from the pulls (tangent points fixed on B)
// must equal -dL/dq by central differences: always in exact mode, and in OpenSim mode where its
// path is a shortest path.
struct ThreeBodies {
  V3 axis[3], pivot[3];
  double rate[3];
  Eigen::Isometry3d Pose(int body, double q) const {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translate(pivot[body]);
    X.rotate(Eigen::AngleAxisd(rate[body] * q, axis[body]));
    X.translate(-pivot[body]);
    return X;
  }
  V3 Velocity(int body, double q, const V3& x) const {
    (void)q;
    return rate[body] * axis[body].cross(x - pivot[body]);
  }
};

void CheckPullsAgainstDifferences(const WrapSurface& surface, WrapMode mode, unsigned seed,
                                  double tolerance) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 20; ++trial) {
    ThreeBodies b;
    for (int k = 0; k < 3; ++k) {
      b.axis[k] = V3(u(rng), u(rng), u(rng)).normalized();
      b.pivot[k] = 0.02 * V3(u(rng), u(rng), u(rng));
      b.rate[k] = u(rng);
    }
    const double scale = 0.01;
    const V3 dir = V3(u(rng), u(rng), u(rng)).normalized();
    const V3 side = dir.unitOrthogonal();
    // Through the sphere, ellipsoid or cylinder near its centre; through a torus's tube.
    const double offset = surface.shape == WrapShape::kTorus ? 0.018 : 0.0;
    const V3 P = scale * (3 + u(rng)) * dir + (offset + 0.3 * scale * u(rng)) * side;
    const V3 N =
        -scale * (3 + u(rng)) * dir + (offset + 0.3 * scale * u(rng)) * side +
        (surface.shape == WrapShape::kTorus ? 0.0 : 0.3 * scale * u(rng)) * dir.cross(side);
    Eigen::Isometry3d X_S = Eigen::Isometry3d::Identity();
    if (surface.shape == WrapShape::kCylinder || surface.shape == WrapShape::kTorus) {
      // Cylinder axis / torus axis across the segment (z perpendicular to P -> N).
      Eigen::Matrix3d R;
      R.col(2) = (N - P).cross(side).normalized();
      if (surface.shape == WrapShape::kTorus) R.col(2) = (N - P).normalized();
      R.col(0) = R.col(2).unitOrthogonal();
      R.col(1) = R.col(2).cross(R.col(0));
      X_S.linear() = R;
    }
    auto evaluate = [&](double q, WrappedPath& out) {
      WrapPathInput in;
      in.points = {b.Pose(0, q) * P, b.Pose(2, q) * N};
      in.active = {1, 1};
      WrapPathWrap w;
      w.surface = surface;
      w.X_W_S = b.Pose(1, q) * X_S;
      w.first = 0;
      w.last = 1;
      in.wraps.push_back(w);
      ComputeWrappedPath(in, mode, out);
      return in;
    };
    const double q0 = 0.1 * u(rng);
    WrappedPath out;
    const WrapPathInput in = evaluate(q0, out);
    if (!out.wraps[0].wrapped || (out.status & (kWrapExactFallback | kWrapNotConverged))) continue;
    double dL = out.point_pull[0].dot(b.Velocity(0, q0, in.points[0])) +
                out.point_pull[1].dot(b.Velocity(2, q0, in.points[1])) +
                out.wraps[0].pull_r1.dot(b.Velocity(1, q0, out.wraps[0].r1)) +
                out.wraps[0].pull_r2.dot(b.Velocity(1, q0, out.wraps[0].r2));
    const double h = 1e-6;
    WrappedPath plus, minus;
    evaluate(q0 + h, plus);
    evaluate(q0 - h, minus);
    if (!plus.wraps[0].wrapped || !minus.wraps[0].wrapped) continue;
    const double difference = (plus.length - minus.length) / (2 * h);
    EXPECT_NEAR(dL, difference, tolerance * (1 + std::abs(difference)))
        << WrapShapeName(surface.shape) << " " << WrapModeName(mode) << " trial " << trial;
    ++checked;
  }
  EXPECT_GT(checked, 5) << WrapShapeName(surface.shape) << " " << WrapModeName(mode);
}

TEST(WrappedPathTest, ExactModeMomentArmFromPullsIsMinusDLdqOnEveryShape) {
  WrapSurface cylinder, sphere, ellipsoid, torus;
  cylinder.shape = WrapShape::kCylinder;
  cylinder.radius = 0.008;
  cylinder.length = 0.2;
  sphere.shape = WrapShape::kSphere;
  sphere.radius = 0.008;
  ellipsoid.shape = WrapShape::kEllipsoid;
  ellipsoid.radii = V3(0.008, 0.011, 0.006);
  torus.shape = WrapShape::kTorus;
  torus.inner_radius = 0.004;
  torus.outer_radius = 0.02;
  CheckPullsAgainstDifferences(cylinder, WrapMode::kExact, 1, 1e-7);
  CheckPullsAgainstDifferences(sphere, WrapMode::kExact, 2, 1e-7);
  CheckPullsAgainstDifferences(ellipsoid, WrapMode::kExact, 3, 1e-6);
  CheckPullsAgainstDifferences(torus, WrapMode::kExact, 4, 1e-6);
  // OpenSim's sphere is a shortest path: its moment arm is -dL/dq too.
  CheckPullsAgainstDifferences(sphere, WrapMode::kOpenSim, 5, 1e-7);
}

TEST(WrappedPathTest, LengthIsContinuousWhereASingleWrapEngages) {
  // N moves down past the cylinder: the straight line turns tangent, then wraps.
  const double R = 0.01;
  const V3 P(0.04, R, 0);
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    auto length = [&](double y, bool* wrapped) {
      WrapPathInput in = Points({P, V3(-0.04, y, 0.0)});
      in.wraps.push_back(PathCylinder(R, V3::Zero(), 0, 1));
      WrappedPath out;
      ComputeWrappedPath(in, mode, out);
      *wrapped = out.wraps[0].wrapped;
      return out.length;
    };
    // Bisect the engagement (y = R: the line tangent at the top).
    double lo = R - 0.002, hi = R + 0.002;
    bool w = false;
    for (int i = 0; i < 45; ++i) {  // down to 1e-16 m
      const double mid = 0.5 * (lo + hi);
      length(mid, &w);
      (w ? lo : hi) = mid;
    }
    bool wl = false, wh = false;
    const double Llo = length(lo, &wl), Lhi = length(hi, &wh);
    EXPECT_TRUE(wl);
    EXPECT_FALSE(wh);
    EXPECT_NEAR(Llo, Lhi, 1e-12) << WrapModeName(mode);
    EXPECT_NEAR(hi, R, 1e-9);
  }
}

TEST(WrappedPathTest, SeveralWrapsIterateUntilTheLengthSettles) {
  // Two cylinders side by side under a straight line: each wrap is computed on the path left by
  // the other, the passes stop when two lengths agree within 0.5 mm.
  const V3 P(0.06, 0.002, 0), N(-0.06, 0.002, 0);
  WrapPathInput in = Points({P, N});
  in.wraps.push_back(PathCylinder(0.01, V3(0.02, 0, 0), 0, 1));
  in.wraps.push_back(PathCylinder(0.01, V3(-0.02, 0, 0), 0, 1));
  WrappedPath out;
  ComputeWrappedPath(in, WrapMode::kExact, out);
  ASSERT_TRUE(out.wraps[0].wrapped);
  ASSERT_TRUE(out.wraps[1].wrapped);
  EXPECT_GE(out.passes, 2);
  EXPECT_EQ(out.status & kWrapNotConverged, 0u);
  // Over two equal cylinders on a common tangent y = 0.01: P -> tangent, arc, the straight
  // common tangent 0.04 long, arc, tangent -> N (planar closed form).
  const double d = std::hypot(0.04, 0.002);
  const double t = std::sqrt(d * d - 0.01 * 0.01);
  const double arc = 0.01 * (kPiPath / 2 - std::acos(0.01 / d) - std::atan2(0.002, 0.04));
  EXPECT_NEAR(out.length, 2 * t + 2 * arc + 0.04, 1e-9);
  EXPECT_EQ(out.elements.size(), 6u);
}

TEST(WrappedPathTest, CheckWrapsNamesTheMuscleTheObjectAndTheRule) {
  LimbDescription d;
  d.name = "leg";
  d.root_link = "ground";
  d.links = {"ground", "femur"};
  MuscleSpec m;
  m.name = "VAS";
  m.path = {PathPoint("ground", V3::Zero()), PathPoint("femur", V3(0.01, 0, 0))};
  WrapObjectSpec cyl;
  cyl.name = "knee";
  cyl.link = "femur";
  cyl.shape = WrapShape::kCylinder;
  cyl.radius = 0.004;
  cyl.length = 0.02;
  d.wrap_objects = {cyl};
  m.wraps = {PathWrapSpec{"knee", -1, -1, WrapMethod::kHybrid}};
  d.muscles = {m};
  EXPECT_NO_THROW(CheckWraps(d, "model 'leg'"));
  auto expect_error = [&](const LimbDescription& bad, const std::string& text) {
    try {
      CheckWraps(bad, "model 'leg'");
      ADD_FAILURE() << "no error for " << text;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(text));
    }
  };
  LimbDescription bad = d;
  bad.wrap_objects[0].radius = -0.004;
  expect_error(bad, "wrap object 'knee' (cylinder on 'femur'): radius -0.004 m must be");
  bad = d;
  bad.wrap_objects[0].length = 0.0;
  expect_error(bad, "length 0 m");
  bad = d;
  bad.wrap_objects[0].shape = WrapShape::kTorus;
  bad.wrap_objects[0].inner_radius = 0.02;
  bad.wrap_objects[0].outer_radius = 0.01;
  expect_error(bad, "inner_radius 0.02 m must be below outer_radius 0.01 m");
  bad = d;
  bad.muscles[0].wraps[0].object = "kne";
  expect_error(
      bad, "muscle 'VAS', wrap 1 ('kne'): no wrap object is called 'kne' (did you mean 'knee'?)");
  bad = d;
  bad.muscles[0].wraps[0].range_last = 3;
  expect_error(bad, "muscle 'VAS', wrap 1 ('knee'): range -1 3 is outside the path's 2 points");
  bad = d;
  bad.muscles[0].wraps[0].range_first = 2;
  bad.muscles[0].wraps[0].range_last = 1;
  expect_error(bad, "range 2 1");
  bad = d;
  bad.wrap_objects[0].link = "tibia";
  expect_error(bad, "link 'tibia' is not on the chain");
}

}  // namespace
}  // namespace isowrench
