// One segment over one wrap surface (WrapSegment): closed forms, an independent shortest-path
// minimiser written here, and the numbers opensim-core's own wrap tests record.

#include "isowrench/wrap.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "isowrench/error.hpp"
#include "wrap/cylinder_single.hpp"
#include "wrap/wrap_impl.hpp"

namespace isowrench {
namespace {

using V3 = Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

WrapSurface Cylinder(double radius, double length, const std::string& quadrant = "all") {
  WrapSurface s;
  s.shape = WrapShape::kCylinder;
  s.radius = radius;
  s.length = length;
  s.quadrant = WrapQuadrant::Parse(quadrant);
  return s;
}

WrapSurface Sphere(double radius, const std::string& quadrant = "all") {
  WrapSurface s;
  s.shape = WrapShape::kSphere;
  s.radius = radius;
  s.quadrant = WrapQuadrant::Parse(quadrant);
  return s;
}

WrapSurface Ellipsoid(const V3& radii, const std::string& quadrant = "all") {
  WrapSurface s;
  s.shape = WrapShape::kEllipsoid;
  s.radii = radii;
  s.quadrant = WrapQuadrant::Parse(quadrant);
  return s;
}

double Total(const WrapSegmentResult& w, const V3& p1, const V3& p2) {
  return (w.r1 - p1).norm() + w.arc_length + (p2 - w.r2).norm();
}

// Planar closed form: P and N in one cross-section of a cylinder of radius R about z (or in a
// plane through a sphere's centre). Tangent lengths sqrt(d^2 - R^2) and the arc R * angle,
// angle = (angle between P and N seen from the axis) - acos(R/dP) - acos(R/dN).
double PlanarWrapLength(double R, const V3& P, const V3& N) {
  const double dP = P.head<2>().norm(), dN = N.head<2>().norm();
  const double between = std::acos(P.head<2>().dot(N.head<2>()) / (dP * dN));
  const double angle = between - std::acos(R / dP) - std::acos(R / dN);
  return std::sqrt(dP * dP - R * R) + std::sqrt(dN * dN - R * R) + R * angle;
}

TEST(WrapSegmentTest, CylinderPerpendicularToPlaneOfMotionHasTheClosedFormLength) {
  std::mt19937 rng(27);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int wrapped = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const double R = 0.004 + 0.01 * (u(rng) + 1.0);
    const double z = 0.01 * u(rng);
    // P on one side, N on the other, the line passing within R of the axis.
    const double aP = kPi * u(rng);
    const double dP = R * (1.2 + 3.0 * (u(rng) + 1.0));
    const double dN = R * (1.2 + 3.0 * (u(rng) + 1.0));
    const double aN = aP + kPi + 0.5 * u(rng);
    const V3 P(dP * std::cos(aP), dP * std::sin(aP), z);
    const V3 N(dN * std::cos(aN), dN * std::sin(aN), z);
    const WrapSurface cyl = Cylinder(R, 0.05);
    for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
      const WrapSegmentResult w = WrapSegment(cyl, P, N, mode);
      const bool crosses =
          std::abs(P.head<2>().x() * N.head<2>().y() - P.head<2>().y() * N.head<2>().x()) /
              (N - P).head<2>().norm() <
          R;
      ASSERT_EQ(w.wraps, crosses) << "trial " << trial << " mode " << WrapModeName(mode);
      if (!crosses) continue;
      ++wrapped;
      EXPECT_NEAR(Total(w, P, N), PlanarWrapLength(R, P, N), 1e-12)
          << "trial " << trial << " mode " << WrapModeName(mode);
      EXPECT_NEAR(w.r1.head<2>().norm(), R, 1e-13);
      EXPECT_NEAR(w.r2.head<2>().norm(), R, 1e-13);
      EXPECT_NEAR(w.r1.z(), z, 1e-13);
    }
  }
  EXPECT_GT(wrapped, 100);
}

// testWrapCylinder.cpp (opensim-core OpenSim/Tests/Wrapping): the tangent points and lengths
// OpenSim 4.5 recorded for a unit cylinder, 10 long, all quadrants; and the reversed paths.
TEST(WrapSegmentTest, CylinderMatchesOpenSimsRecordedTangentPoints) {
  struct Case {
    V3 p1, p2, r1, r2;
    double length;
  };
  const Case cases[] = {
      {V3(2, 0.9, 0), V3(-2, 1.0, 0), V3(0.0505759009075089, 0.998720220205536, 0), V3(0, 1, 0),
       0.0505974872969326},
      {V3(2, -2, 0), V3(-2, 2.1, 0), V3(0.911437827766147, 0.411437827766148, 0),
       V3(0.441911556159668, 0.897058624913969, 0), 0.689036814042993},
  };
  const WrapSurface cyl = Cylinder(1.0, 10.0);
  for (const Case& c : cases) {
    for (bool reversed : {false, true}) {
      const V3& a = reversed ? c.p2 : c.p1;
      const V3& b = reversed ? c.p1 : c.p2;
      const WrapSegmentResult w = WrapSegment(cyl, a, b, WrapMode::kOpenSim);
      ASSERT_TRUE(w.wraps);
      EXPECT_LT(((reversed ? c.r2 : c.r1) - w.r1).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_LT(((reversed ? c.r1 : c.r2) - w.r2).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_NEAR(w.arc_length, c.length, 1e-9);
    }
  }
  // "Inside cylinder": no wrap.
  EXPECT_FALSE(WrapSegment(cyl, V3::Zero(), V3::Zero(), WrapMode::kOpenSim).wraps);
  EXPECT_EQ(WrapSegment(cyl, V3::Zero(), V3::Zero(), WrapMode::kOpenSim).action,
            WrapAction::kInsideRadius);
}

// testGeometryPathWrapping.cpp testSingleWrapObjectPerpendicular: origin (r - 0.1, r, 0) on
// ground, insertion (-r, r, 0) on a body turning by q about z; the object (radius r = 0.5) at
// the ground's origin. OpenSim asserts L = 2r - 0.1 + r q (1e-6) and moment arm -r (1e-4) for q
// in [0, pi/2], for cylinders and spheres turned about their axes, ellipsoids of radii r, r, r.
TEST(WrapSegmentTest, PerpendicularWrapMatchesOpenSimsAnalyticCase) {
  const double r = 0.5;
  std::vector<std::pair<WrapSurface, V3>> objects;
  for (const V3& rot : {V3(0, 0, 0), V3(0, 0, kPi / 2), V3(0, 0, kPi), V3(0, 0, -kPi / 2)}) {
    objects.emplace_back(Cylinder(r, 1.0), rot);
    objects.emplace_back(Sphere(r), rot);
    objects.emplace_back(Ellipsoid(V3::Constant(r)), rot);
  }
  for (const V3& rot : {V3(0, kPi / 2, 0), V3(0, kPi, 0), V3(kPi / 2, 0, 0), V3(kPi, 0, 0)}) {
    objects.emplace_back(Sphere(r), rot);
  }
  objects.emplace_back(Cylinder(r, 1.0, "+y"), V3::Zero());
  objects.emplace_back(Sphere(r, "+y"), V3::Zero());
  objects.emplace_back(Ellipsoid(V3::Constant(r), "+y"), V3::Zero());
  for (const auto& [surface, rot] : objects) {
    WrapObjectSpec spec;
    spec.xyz_body_rotation = rot;
    const Eigen::Isometry3d X = spec.Pose();  // X_ground_S
    for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
      for (int i = 0; i <= 20; ++i) {
        const double q = i * kPi / 40;
        const Eigen::Matrix3d Rz = Eigen::AngleAxisd(q, V3::UnitZ()).toRotationMatrix();
        const V3 origin(r - 0.1, r, 0);
        const V3 insertion = Rz * V3(-r, r, 0);
        const V3 a = X.inverse() * origin, b = X.inverse() * insertion;
        const WrapSegmentResult w = WrapSegment(surface, a, b, mode);
        const std::string what = std::string(WrapShapeName(surface.shape)) + " " +
                                 surface.quadrant.ToString() + " rot " + std::to_string(rot.x()) +
                                 "," + std::to_string(rot.y()) + "," + std::to_string(rot.z()) +
                                 " q " + std::to_string(q) + " " + WrapModeName(mode);
        if (i == 0) continue;  // tangent at q = 0: wrapping or not, the length is the same
        ASSERT_TRUE(w.wraps) << what;
        const double tolerance =
            surface.shape == WrapShape::kEllipsoid && mode == WrapMode::kOpenSim ? 1e-6 : 1e-9;
        EXPECT_NEAR(Total(w, a, b), 2 * r - 0.1 + r * q, tolerance) << what;
        // Moment arm from the pull at the insertion (the object is on ground): -pull . dx/dq.
        const V3 pull = (X * w.r2 - insertion).normalized() * -1.0;  // dL/dx at the insertion
        const double moment_arm = -pull.dot(V3::UnitZ().cross(insertion));
        EXPECT_NEAR(moment_arm, -r, surface.shape == WrapShape::kEllipsoid ? 1e-4 : 1e-9) << what;
      }
    }
  }
}

// ---- an independent shortest-path minimiser --------------------------------------------------

// Newton's method on an analytic gradient (its Hessian by central differences of the
// gradient) with a backtracking line search on f, over dimensionless parameters x: minimises f.
template <class Function, class Gradient>
Eigen::VectorXd Minimise(Eigen::VectorXd x, const Function& f, const Gradient& gradient) {
  for (int it = 0; it < 200; ++it) {
    const Eigen::VectorXd g = gradient(x);
    if (g.norm() < 1e-16) break;
    const int n = static_cast<int>(x.size());
    Eigen::MatrixXd H(n, n);
    for (int k = 0; k < n; ++k) {
      const double h = 1e-6;
      Eigen::VectorXd xp = x, xm = x;
      xp[k] += h;
      xm[k] -= h;
      H.col(k) = (gradient(xp) - gradient(xm)) / (2 * h);
    }
    H = 0.5 * (H + H.transpose()).eval();
    Eigen::VectorXd dx = -g;  // steepest descent unless the Hessian is positive definite
    Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
    if (ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 0).all()) dx = ldlt.solve(-g);
    if (dx.dot(g) >= 0) dx = -g;
    double step = 1.0;
    const double f0 = f(x);
    while (f(x + step * dx) > f0 && step > 1e-12) step *= 0.5;
    if (!(f(x + step * dx) <= f0)) break;
    x += step * dx;
  }
  return x;
}

// The straight segments of a wrapped path are tangent to the surface, so each tangent point
// lies on its end point's "horizon": for a cylinder about z, the generator through the 2D
// tangent point (the point where the line from P touches the circle, on the side the path
// turns); for a sphere, the circle of points r with r . P = R^2. The minimiser moves the
// tangent points over their horizons, which keeps the straight segments outside the surface
// (over the whole surface the length has a degenerate critical point there and slides inside).

// Cylinder: x = (z1, z2) / R, the tangent generators fixed by the 2D construction.
struct CylinderPath {
  double R, t1, t2, turn;  // 2D tangent lengths and the angle turned (rad)
  double zP, zN;
  double Length(const Eigen::VectorXd& x) const {
    const double z1 = R * x[0], z2 = R * x[1];
    return std::hypot(t1, z1 - zP) + std::hypot(R * turn, z2 - z1) + std::hypot(t2, zN - z2);
  }
  Eigen::VectorXd Gradient(const Eigen::VectorXd& x) const {
    const double z1 = R * x[0], z2 = R * x[1];
    const double a = std::hypot(t1, z1 - zP), b = std::hypot(R * turn, z2 - z1),
                 c = std::hypot(t2, zN - z2);
    Eigen::VectorXd g(2);
    g << (z1 - zP) / a - (z2 - z1) / b, (z2 - z1) / b - (zN - z2) / c;
    return g;  // d(L / R) / dx
  }
};

// The 2D tangent point of the circle of radius R seen from P (xy), on the side that turns with
// sense s (+1 counter-clockwise) towards the other end.
double TangentAngle(double R, const V3& P, int s, bool leaving) {
  const double d = P.head<2>().norm();
  const double base = std::atan2(P.y(), P.x());
  return leaving ? base + s * std::acos(R / d) : base - s * std::acos(R / d);
}

TEST(WrapSegmentTest, ExactCylinderEqualsAnIndependentShortestPathMinimisation) {
  std::mt19937 rng(271);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const double R = 0.003 + 0.01 * (u(rng) + 1.0);
    const double aP = kPi * u(rng), aN = aP + kPi + 0.6 * u(rng);
    const double dP = R * (1.5 + 3 * (u(rng) + 1)), dN = R * (1.5 + 3 * (u(rng) + 1));
    const V3 P(dP * std::cos(aP), dP * std::sin(aP), 0.02 * u(rng));
    const V3 N(dN * std::cos(aN), dN * std::sin(aN), 0.02 * u(rng));
    const WrapSegmentResult w = WrapSegment(Cylinder(R, 0.2), P, N, WrapMode::kExact);
    if (!w.wraps) continue;
    // The short way round (an unconstrained cylinder): the sense that passes the axis on the
    // side the straight line passes it.
    const double cross = P.x() * N.y() - P.y() * N.x();
    const int s = cross >= 0 ? 1 : -1;
    const double a1 = TangentAngle(R, P, s, true), a2 = TangentAngle(R, N, s, false);
    double turn = std::fmod(s * (a2 - a1), 2 * kPi);
    if (turn < 0) turn += 2 * kPi;
    CylinderPath path{R,    std::sqrt(dP * dP - R * R), std::sqrt(dN * dN - R * R), turn, P.z(),
                      N.z()};
    Eigen::VectorXd x(2);
    x << P.z() / R + 0.3, N.z() / R - 0.3;  // start at neither answer
    x = Minimise(
        x, [&](const Eigen::VectorXd& y) { return path.Length(y); },
        [&](const Eigen::VectorXd& y) { return path.Gradient(y); });
    const V3 r1(R * std::cos(a1), R * std::sin(a1), R * x[0]);
    const V3 r2(R * std::cos(a2), R * std::sin(a2), R * x[1]);
    EXPECT_NEAR(Total(w, P, N), path.Length(x), 1e-9) << "trial " << trial;
    EXPECT_LT((r1 - w.r1).norm(), 1e-9) << "trial " << trial;
    EXPECT_LT((r2 - w.r2).norm(), 1e-9) << "trial " << trial;
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

// Sphere: x = (psi1, psi2), the angles of the tangent points on the horizons of P and N; the
// surface path between them the great-circle arc R acos(r1 . r2 / R^2).
struct SpherePath {
  double R;
  V3 P, N;
  struct Horizon {
    V3 c, e1, e2;
    double rho;
  } h1, h2;
  static Horizon Of(double R, const V3& X) {
    Horizon h;
    h.c = (R * R / X.squaredNorm()) * X;
    h.rho = R * std::sqrt(1 - R * R / X.squaredNorm());
    h.e1 = X.unitOrthogonal();
    h.e2 = X.normalized().cross(h.e1);
    return h;
  }
  static V3 At(const Horizon& h, double psi) {
    return h.c + h.rho * (std::cos(psi) * h.e1 + std::sin(psi) * h.e2);
  }
  static V3 Along(const Horizon& h, double psi) {
    return h.rho * (-std::sin(psi) * h.e1 + std::cos(psi) * h.e2);
  }
  double Length(const Eigen::VectorXd& x) const {
    const V3 r1 = At(h1, x[0]), r2 = At(h2, x[1]);
    return (r1 - P).norm() + R * std::acos(std::clamp(r1.dot(r2) / (R * R), -1.0, 1.0)) +
           (N - r2).norm();
  }
  Eigen::VectorXd Gradient(const Eigen::VectorXd& x) const {
    const V3 r1 = At(h1, x[0]), r2 = At(h2, x[1]);
    const double c = r1.dot(r2) / (R * R);
    const double k = -1.0 / std::sqrt(1 - c * c);  // d(acos c)/dc; L / R = ... + acos(c)
    Eigen::VectorXd g(2);
    g << k * Along(h1, x[0]).dot(r2) / (R * R), k * Along(h2, x[1]).dot(r1) / (R * R);
    return g;  // (the tangent lengths are constant on the horizons)
  }
};

TEST(WrapSegmentTest, ExactSphereEqualsAnIndependentShortestPathMinimisation) {
  std::mt19937 rng(2727);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const double R = 0.003 + 0.01 * (u(rng) + 1.0);
    const V3 dir = V3(u(rng), u(rng), u(rng)).normalized();
    const V3 side = dir.unitOrthogonal();
    const V3 P = R * (2 + 3 * (u(rng) + 1)) * dir + 0.5 * R * u(rng) * side;
    const V3 N = -R * (2 + 3 * (u(rng) + 1)) * dir + 0.5 * R * u(rng) * side +
                 0.5 * R * u(rng) * dir.cross(side);
    for (WrapMode mode : {WrapMode::kExact, WrapMode::kOpenSim}) {  // OpenSim's sphere is exact
      const WrapSegmentResult w = WrapSegment(Sphere(R), P, N, mode);
      if (!w.wraps) continue;
      SpherePath path{R, P, N, SpherePath::Of(R, P), SpherePath::Of(R, N)};
      auto angle = [](const SpherePath::Horizon& h, const V3& r) {
        return std::atan2((r - h.c).dot(h.e2), (r - h.c).dot(h.e1));
      };
      Eigen::VectorXd x(2);
      x << angle(path.h1, w.r1) + 0.2, angle(path.h2, w.r2) - 0.2;  // start away from the answer
      x = Minimise(
          x, [&](const Eigen::VectorXd& y) { return path.Length(y); },
          [&](const Eigen::VectorXd& y) { return path.Gradient(y); });
      EXPECT_NEAR(Total(w, P, N), path.Length(x), 1e-9) << "trial " << trial;
      EXPECT_LT((SpherePath::At(path.h1, x[0]) - w.r1).norm(), 1e-9) << "trial " << trial;
      EXPECT_LT((SpherePath::At(path.h2, x[1]) - w.r2).norm(), 1e-9) << "trial " << trial;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

// An ellipsoid of equal radii is a sphere: the exact (numerical geodesic) path equals the
// sphere's closed form.
TEST(WrapSegmentTest, ExactEllipsoidOfEqualRadiiIsTheSphere) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const double R = 0.01;
    const V3 dir = V3(u(rng), u(rng), u(rng)).normalized();
    const V3 side = dir.unitOrthogonal();
    const V3 P = R * (2 + (u(rng) + 1)) * dir + 0.4 * R * u(rng) * side;
    const V3 N = -R * (2 + (u(rng) + 1)) * dir + 0.4 * R * u(rng) * dir.cross(side);
    const WrapSegmentResult sphere = WrapSegment(Sphere(R), P, N, WrapMode::kExact);
    const WrapSegmentResult ell = WrapSegment(Ellipsoid(V3::Constant(R)), P, N, WrapMode::kExact);
    if (!sphere.wraps) continue;
    ASSERT_TRUE(ell.wraps) << trial;
    EXPECT_EQ(ell.status & kWrapExactFallback, 0u) << WrapStatusText(ell.status);
    EXPECT_NEAR(Total(ell, P, N), Total(sphere, P, N), 1e-9) << trial;
    EXPECT_LT((ell.r1 - sphere.r1).norm(), 1e-7) << trial;
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

// A true ellipsoid: the exact path is stationary (tangent, on the surface, a geodesic): the
// independent check is that a discretised path over the surface, minimised, converges to its
// length from above as the discretisation is refined.
TEST(WrapSegmentTest, ExactEllipsoidPathIsTangentAndOnTheSurface) {
  const V3 radii(0.012, 0.008, 0.02);
  const V3 P(0.03, 0.004, 0.002), N(-0.028, 0.006, -0.003);
  const WrapSurface e = Ellipsoid(radii);
  const WrapSegmentResult os = WrapSegment(e, P, N, WrapMode::kOpenSim);
  const WrapSegmentResult w = WrapSegment(e, P, N, WrapMode::kExact);
  ASSERT_TRUE(os.wraps);
  ASSERT_TRUE(w.wraps);
  EXPECT_EQ(w.status & (kWrapExactFallback | kWrapNotConverged), 0u) << WrapStatusText(w.status);
  for (const V3& r : {w.r1, w.r2}) {
    EXPECT_NEAR(r.cwiseQuotient(radii).squaredNorm(), 1.0, 1e-12);
  }
  const V3 n1 = w.r1.cwiseQuotient(radii.cwiseProduct(radii)).normalized();
  const V3 n2 = w.r2.cwiseQuotient(radii.cwiseProduct(radii)).normalized();
  EXPECT_NEAR(n1.dot((w.r1 - P).normalized()), 0.0, 1e-9);
  EXPECT_NEAR(n2.dot((N - w.r2).normalized()), 0.0, 1e-9);
  // Never shorter than the straight line; within a few tenths of a millimetre of OpenSim's
  // planar approximation here (which is not a geodesic, and whose 1 mm chords cut inside).
  EXPECT_GT(Total(w, P, N), (N - P).norm());
  EXPECT_NEAR(Total(w, P, N), Total(os, P, N), 3e-4);
}

TEST(WrapSegmentTest, ConstrainedCylinderWrapsAroundItsSideOrNotAtAll) {
  // Both points on the -y side, the straight line clear of the cylinder on that side.
  const V3 P(0.03, -0.012, 0), N(-0.03, -0.012, 0);
  const double R = 0.01;
  EXPECT_FALSE(WrapSegment(Cylinder(R, 0.1, "all"), P, N, WrapMode::kOpenSim).wraps);
  EXPECT_FALSE(WrapSegment(Cylinder(R, 0.1, "-y"), P, N, WrapMode::kOpenSim).wraps);
  // "+y": the path must pass on the +y side: it goes the long way round, over the top.
  for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    const WrapSegmentResult w = WrapSegment(Cylinder(R, 0.1, "+y"), P, N, mode);
    ASSERT_TRUE(w.wraps) << WrapModeName(mode);
    EXPECT_GT(w.r1.y(), 0.0);
    EXPECT_GT(w.r2.y(), 0.0);
    // Over the top: the planar closed form, by symmetry 2 t + R (pi - 2 b) with t the tangent
    // length and b the angle of the tangent points above the x axis.
    const double d = P.head<2>().norm();
    const double t = std::sqrt(d * d - R * R);
    const double below = std::atan2(0.012, 0.03);  // P's angle below the x axis
    const double beta = std::acos(R / d) - below;  // tangent point's angle above the x axis
    EXPECT_NEAR(Total(w, P, N), 2 * t + R * (kPi - 2 * beta), 1e-12) << WrapModeName(mode);
  }
  // Spellings OpenSim accepts.
  EXPECT_EQ(WrapQuadrant::Parse("x"), WrapQuadrant::Parse("+X"));
  EXPECT_EQ(WrapQuadrant::Parse("-Z").ToString(), "-z");
  EXPECT_EQ(WrapQuadrant::Parse("All").ToString(), "all");
  EXPECT_THROW(WrapQuadrant::Parse("+w"), Error);
}

// The engine's cylinder for a muscle with one wrap (OpenSimCylinderSingle, the axis written
// out) against the line-by-line port of WrapCylinder::wrapLine it replaces there
// (OpenSimCylinder, single_wrap): the same code, side and tangent points on random segments
// around random cylinders of every quadrant, and on the degenerate ones (parallel to the axis,
// zero length, an end point on the surface, close to the axis, beyond the cylinder's ends).
TEST(WrapSegmentTest, OneWrapCylinderEqualsThePortedWrapLine) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const char* quadrants[] = {"all", "+x", "-x", "+y", "-y", "+z", "-z"};
  int codes[4] = {0, 0, 0, 0}, far = 0, compared = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const double R = 0.002 + 0.018 * (0.5 + 0.5 * u(rng));
    const double L = 0.005 + 0.095 * (0.5 + 0.5 * u(rng));
    const WrapQuadrant quadrant = WrapQuadrant::Parse(quadrants[trial % 7]);
    V3 P(3 * R * u(rng), 3 * R * u(rng), L * u(rng)), N(3 * R * u(rng), 3 * R * u(rng), L * u(rng));
    switch (trial % 50) {
      case 0: N.head<2>() = P.head<2>(); break;                   // parallel to the axis
      case 1: N = P; break;                                       // zero length
      case 2: P.head<2>() = R * P.head<2>().normalized(); break;  // on the surface
      case 3:  // close to the axis (exactly through it, t = 1/2, the apex is rounding noise)
        N.head<2>() = -0.7 * (Eigen::Rotation2Dd(0.05) * P.head<2>());
        break;
      case 4:  // beyond an end
        P.z() = 2 * L;
        N.z() = 3 * L;
        break;
      default: break;
    }
    const wrap_impl::OsSegment port = wrap_impl::OpenSimCylinder(R, L, quadrant, P, N, true);
    const wrap_impl::OsSegment lean = wrap_impl::OpenSimCylinderSingle(R, L, quadrant, P, N);
    const std::string where = "trial " + std::to_string(trial) + " quadrant " + quadrant.ToString();
    ASSERT_EQ(lean.code, port.code) << where;
    ASSERT_EQ(lean.has_path, port.has_path) << where;
    ASSERT_EQ(lean.flag, port.flag) << where;
    ++codes[port.code];
    if (!port.has_path) continue;
    ASSERT_EQ(lean.far_side, port.far_side) << where;
    ASSERT_EQ(lean.sense, port.sense) << where;
    // (the tangent points slide along the axis onto a plane that can be steep: their z carries
    // the port's rounding, ~1e-16 m, amplified up to ~1e-13 m here and ~1e-11 m in one of a
    // million random segments close to the axis)
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(lean.r1[k], port.r1[k], 1e-11) << where;
      ASSERT_NEAR(lean.r2[k], port.r2[k], 1e-11) << where;
    }
    ASSERT_NEAR(lean.length, port.length, 1e-12) << where;
    far += port.far_side ? 1 : 0;
    ++compared;
  }
  // Every outcome is met many times: no wrap, an end point inside, wrapped, mandatory, the long
  // way round.
  for (int c = 0; c < 4; ++c) EXPECT_GT(codes[c], 500) << "code " << c;
  EXPECT_GT(far, 500);
  EXPECT_GT(compared, 5000);
}

// The cylinder's atan2 (wrap/cylinder_single.hpp) against libm's: random angles over every
// octant and small and large ratios, and the signed zeros, the axes and NaN.
TEST(WrapSegmentTest, CylinderAtan2IsLibmsWithinAnUlpOfPi) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    double y = u(rng), x = u(rng);
    if (i % 3 == 0) y *= 1e-7;
    if (i % 5 == 0) x *= 1e-9;
    worst = std::max(worst, std::fabs(wrap_impl::cylinder_single::Atan2(y, x) - std::atan2(y, x)));
  }
  EXPECT_LE(worst, 4.5e-16);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [y, x] : std::vector<std::pair<double, double>>{{0.0, 0.0},
                                                                   {-0.0, 0.0},
                                                                   {0.0, -0.0},
                                                                   {-0.0, -0.0},
                                                                   {0.0, -1.0},
                                                                   {-0.0, -1.0},
                                                                   {1.0, 0.0},
                                                                   {-1.0, 0.0},
                                                                   {1.0, 1.0},
                                                                   {1.0, -1.0},
                                                                   {-2.0, -2.0}}) {
    const double mine = wrap_impl::cylinder_single::Atan2(y, x);
    EXPECT_NEAR(mine, std::atan2(y, x), 4.5e-16) << y << " " << x;
    EXPECT_EQ(std::signbit(mine), std::signbit(std::atan2(y, x))) << y << " " << x;
  }
  EXPECT_TRUE(std::isnan(wrap_impl::cylinder_single::Atan2(nan, 1.0)));
  EXPECT_TRUE(std::isnan(wrap_impl::cylinder_single::Atan2(1.0, nan)));
}

TEST(WrapSegmentTest, ConstrainedSphereFarSideArcIsNegativeInOpenSimAndPositiveWhenExact) {
  // Both points below the centre and close to the sphere, the line through it: "+y" sends the
  // path over the top, an arc of about 248 degrees.
  const double R = 0.01;
  const V3 P(0.006, -0.009, 0.0005), N(-0.006, -0.009, 0.0);
  const WrapSegmentResult os = WrapSegment(Sphere(R, "+y"), P, N, WrapMode::kOpenSim);
  const WrapSegmentResult ex = WrapSegment(Sphere(R, "+y"), P, N, WrapMode::kExact);
  ASSERT_TRUE(os.wraps);
  ASSERT_TRUE(ex.wraps);
  EXPECT_LT(os.arc_length, 0.0);
  EXPECT_TRUE(os.status & kWrapNegativeArc);
  EXPECT_TRUE(os.status & kWrapBelowStraightLine);
  EXPECT_GT(ex.arc_length, kPi * R);  // the long way round
  EXPECT_EQ(ex.status & kWrapNegativeArc, 0u);
  // OpenSim's arc is -(2 pi R - the short arc) between the same tangent points.
  EXPECT_NEAR(os.arc_length,
              -(2 * kPi * R - R * std::acos(os.r1.normalized().dot(os.r2.normalized()))), 1e-15);
}

TEST(WrapSegmentTest, NeverNaNOnRandomAndDegenerateSegments) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<WrapSurface> surfaces = {Cylinder(0.01, 0.05),
                                       Cylinder(0.01, 0.05, "-x"),
                                       Sphere(0.01),
                                       Sphere(0.01, "+z"),
                                       Ellipsoid(V3(0.01, 0.02, 0.015)),
                                       Ellipsoid(V3(0.01, 0.02, 0.015), "y")};
  WrapSurface torus;
  torus.shape = WrapShape::kTorus;
  torus.inner_radius = 0.004;
  torus.outer_radius = 0.012;
  surfaces.push_back(torus);
#ifdef ISOWRENCH_TEST_SANITIZED
  const int trials = 3;  // the three degenerate cases still run; pass 1 runs all 20
#else
  const int trials = 20;
#endif
  for (int trial = 0; trial < trials; ++trial) {
    V3 P = 0.04 * V3(u(rng), u(rng), u(rng)), N = 0.04 * V3(u(rng), u(rng), u(rng));
    if (trial % 10 == 0) N = -P;              // through the centre
    if (trial % 10 == 1) N = P;               // zero length
    if (trial % 10 == 2) P = V3(0.01, 0, 0);  // on the surface
    for (const WrapSurface& s : surfaces) {
      for (WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
        for (WrapMethod method : {WrapMethod::kHybrid, WrapMethod::kMidpoint, WrapMethod::kAxial}) {
          const WrapSegmentResult w = WrapSegment(s, P, N, mode, method, trial % 2 == 0);
          ASSERT_TRUE(w.r1.allFinite() && w.r2.allFinite() && std::isfinite(w.arc_length))
              << WrapShapeName(s.shape) << " trial " << trial;
        }
      }
    }
  }
}

}  // namespace
}  // namespace isowrench
