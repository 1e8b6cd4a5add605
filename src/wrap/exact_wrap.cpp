// Exact mode: the stationary path over a wrap surface between two points, on the side OpenSim's
// algorithm chose (its sense of rotation, its plane, its tangent points as the starting guess).
//  - cylinder: the surface made of the two tangent lines and the cylinder unrolls to a plane,
//    so the path is a straight line there: in the cross-section the tangent lengths
//    t = sqrt(d^2 - R^2) and the arc R phi, along the axis a uniform rise (a helix);
//  - sphere: a great circle in the plane through the centre and the two points;
//  - ellipsoid, torus: a geodesic integrated on the implicit surface (RK4 with projection),
//    its start point and length found by Newton's method so that both straight segments are
//    tangent to it.
// At such a path dL/d(tangent point along the surface) = 0, which is what makes the moment arm
// the pulls at fixed tangent points (include/isowrench/wrap.hpp).

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "wrap/wrap_impl.hpp"

namespace isowrench::wrap_impl {
namespace {

constexpr double kTwoPi = 6.28318530717958647692;

struct Circle2D {
  Eigen::Vector2d r1, r2;
  double phi = 0.0;  // angle travelled from r1 to r2, in (0, 2 pi)
  double t1 = 0.0, t2 = 0.0;
};

// Wrap around the circle of radius R at the origin from P to N, travelling with sense s (+1:
// counter-clockwise). False when either point is inside or the straight line P -> N is already
// clear of the circle with the circle on the side the path would wrap (no contact needed).
bool WrapCircle(double R, const Eigen::Vector2d& P, const Eigen::Vector2d& N, int s, Circle2D& c) {
  const double dP = P.norm(), dN = N.norm();
  if (!(dP > R) || !(dN > R)) return false;
  const Eigen::Vector2d d = N - P;
  const double dl = d.norm();
  if (dl > 0.0) {
    // Signed distance of the centre to the left of the line P -> N.
    const double delta = (d.x() * (-P.y()) - d.y() * (-P.x())) / dl;
    if (s * delta >= R) return false;
  }
  const double theta1 = std::atan2(P.y(), P.x()) + s * std::acos(R / dP);
  const double theta2 = std::atan2(N.y(), N.x()) - s * std::acos(R / dN);
  double phi = std::fmod(s * (theta2 - theta1), kTwoPi);
  if (phi < 0.0) phi += kTwoPi;
  // At engagement the tangent points meet: phi is 0, or 2 pi - rounding.
  if (phi > kTwoPi - 1e-9) phi = 0.0;
  c.r1 = R * Eigen::Vector2d(std::cos(theta1), std::sin(theta1));
  c.r2 = R * Eigen::Vector2d(std::cos(theta2), std::sin(theta2));
  c.phi = phi;
  c.t1 = std::sqrt(dP * dP - R * R);
  c.t2 = std::sqrt(dN * dN - R * R);
  return true;
}

OsSegment Fallback(const OsSegment& os) {
  OsSegment out = os;
  out.status |= kWrapExactFallback;
  return out;
}

OsSegment ExactCylinder(double R, const V3& p1, const V3& p2, const OsSegment& os) {
  Circle2D c;
  if (os.sense == 0 || !WrapCircle(R, p1.head<2>(), p2.head<2>(), os.sense, c)) {
    return Fallback(os);
  }
  const double H = c.t1 + R * c.phi + c.t2;
  const double dz = p2.z() - p1.z();
  OsSegment out = os;
  out.r1 = V3(c.r1.x(), c.r1.y(), p1.z() + dz * c.t1 / H);
  out.r2 = V3(c.r2.x(), c.r2.y(), p1.z() + dz * (c.t1 + R * c.phi) / H);
  const double rise = dz * R * c.phi / H;
  out.length = std::sqrt(R * c.phi * R * c.phi + rise * rise);
  return out;
}

OsSegment ExactSphere(double R, const V3& p1, const V3& p2, const OsSegment& os) {
  V3 n = p1.cross(p2);
  if (!(n.norm() > 1e-12 * p1.norm() * p2.norm())) n = os.plane_normal;  // O, P, N collinear
  if (!(n.norm() > 0.0)) return Fallback(os);
  n.normalize();
  const V3 e1 = p1.normalized();
  const V3 e2 = n.cross(e1);
  // The sense OpenSim travels in this plane: from r1 to r2 the short way, or the long way.
  const double turn = os.r1.cross(os.r2).dot(n);
  int s = turn >= 0.0 ? 1 : -1;
  if (os.far_side) s = -s;
  Circle2D c;
  const Eigen::Vector2d P(p1.dot(e1), p1.dot(e2)), N(p2.dot(e1), p2.dot(e2));
  if (!WrapCircle(R, P, N, s, c)) return Fallback(os);
  OsSegment out = os;
  out.r1 = c.r1.x() * e1 + c.r1.y() * e2;
  out.r2 = c.r2.x() * e1 + c.r2.y() * e2;
  out.length = R * c.phi;
  out.status &= ~kWrapNegativeArc;
  return out;
}

// ---- geodesics on an implicit surface F(x) = 0 ---------------------------------------------

struct Implicit {
  WrapShape shape;
  V3 radii;           // ellipsoid
  double R = 0.0;     // torus ring radius
  double r = 0.0;     // torus tube radius
  double rho = 0.0;   // smallest radius of curvature (step size scale)
  double size = 0.0;  // largest dimension: no stationary arc is longer than 4 pi size

  double F(const V3& x) const {
    if (shape == WrapShape::kEllipsoid) return x.cwiseQuotient(radii).squaredNorm() - 1.0;
    const double q = std::hypot(x.x(), x.y()) - R;
    return q * q + x.z() * x.z() - r * r;
  }
  V3 Gradient(const V3& x) const {
    if (shape == WrapShape::kEllipsoid) return 2.0 * x.cwiseQuotient(radii.cwiseProduct(radii));
    const double rho_xy = std::hypot(x.x(), x.y());
    const double k = 2.0 * (rho_xy - R) / rho_xy;
    return V3(k * x.x(), k * x.y(), 2.0 * x.z());
  }
  // v^T Hess(F) v
  double Curvature(const V3& x, const V3& v) const {
    if (shape == WrapShape::kEllipsoid) {
      return 2.0 * v.cwiseQuotient(radii).squaredNorm();
    }
    const double rho_xy = std::hypot(x.x(), x.y());
    const Eigen::Vector2d u(x.x() / rho_xy, x.y() / rho_xy);
    const Eigen::Vector2d vxy(v.x(), v.y());
    const double radial = u.dot(vxy);
    const double k = 2.0 * (rho_xy - R) / rho_xy;
    // Hess = k (I2 - u u^T) + 2 u u^T in xy, 2 in z.
    return k * (vxy.squaredNorm() - radial * radial) + 2.0 * radial * radial + 2.0 * v.z() * v.z();
  }
  V3 Normal(const V3& x) const { return Gradient(x).normalized(); }
  V3 Project(V3 x) const {
    for (int i = 0; i < 50; ++i) {
      const V3 g = Gradient(x);
      const double f = F(x);
      const V3 step = f * g / g.squaredNorm();
      x -= step;
      if (step.norm() < 1e-15 * (1.0 + x.norm())) break;
    }
    return x;
  }
};

struct GeodesicEnd {
  V3 x, v;
};

// Integrate the geodesic from x0 with unit tangent v0 over arc length s (RK4, projecting back
// onto the surface and the tangent plane after each step).
GeodesicEnd Shoot(const Implicit& S, const V3& x0, const V3& v0, double s) {
  const int steps =
      std::clamp(static_cast<int>(std::ceil(std::fabs(s) / (0.01 * S.rho))), 8, 20000);
  const double h = s / steps;
  V3 x = x0, v = v0;
  auto accel = [&](const V3& xx, const V3& vv) {
    const V3 g = S.Gradient(xx);
    return V3(-(S.Curvature(xx, vv) / g.squaredNorm()) * g);
  };
  for (int i = 0; i < steps; ++i) {
    const V3 k1x = v, k1v = accel(x, v);
    const V3 k2x = v + 0.5 * h * k1v, k2v = accel(x + 0.5 * h * k1x, k2x);
    const V3 k3x = v + 0.5 * h * k2v, k3v = accel(x + 0.5 * h * k2x, k3x);
    const V3 k4x = v + h * k3v, k4v = accel(x + h * k3x, k4x);
    x += h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
    v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    x = S.Project(x);
    const V3 n = S.Normal(x);
    v = (v - v.dot(n) * n).normalized();
  }
  return {x, v};
}

// Unknowns z = (alpha, beta, s): r1 = Project(c + alpha e1 + beta e2) with c the start guess and
// e1, e2 its tangent plane; T1 the direction p1 -> r1 in the tangent plane; r2, T2 the geodesic
// end after s. Residuals: p1 in the tangent plane at r1; p2 in the tangent plane at r2 and on
// the line r2 + t T2.
struct GeodesicProblem {
  const Implicit& S;
  V3 p1, p2, c, e1, e2;

  V3 Start(const Eigen::Vector3d& z) const { return S.Project(c + z[0] * e1 + z[1] * e2); }
  Eigen::Vector3d Residual(const Eigen::Vector3d& z, V3* r1_out = nullptr, V3* r2_out = nullptr,
                           double* ahead = nullptr) const {
    if (!(z[2] > 0.0) || !(z[2] < 4.0 * 3.14159265358979 * S.size)) {
      return Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    }
    const V3 r1 = Start(z);
    const V3 n1 = S.Normal(r1);
    V3 d1 = r1 - p1;
    const double l1 = d1.norm();
    d1 /= l1;
    V3 T1 = d1 - d1.dot(n1) * n1;
    T1.normalize();
    const GeodesicEnd end = Shoot(S, r1, T1, z[2]);
    const V3 n2 = S.Normal(end.x);
    V3 d2 = p2 - end.x;
    const double l2 = d2.norm();
    d2 /= l2;
    if (r1_out) *r1_out = r1;
    if (r2_out) *r2_out = end.x;
    if (ahead) *ahead = end.v.dot(d2);
    return Eigen::Vector3d(n1.dot(d1), n2.dot(d2), n2.cross(end.v).dot(d2));
  }
};

OsSegment ExactGeodesic(const Implicit& S, const V3& p1, const V3& p2, const OsSegment& os) {
  if (!os.r1.allFinite() || !os.r2.allFinite() || !(S.F(p1) > 0.0) || !(S.F(p2) > 0.0)) {
    return Fallback(os);
  }
  GeodesicProblem problem{S, p1, p2, S.Project(os.r1), V3::Zero(), V3::Zero()};
  const V3 n = S.Normal(problem.c);
  problem.e1 = n.unitOrthogonal();
  problem.e2 = n.cross(problem.e1);
  const double scale = std::max(S.rho, 1e-6);
  // Start: the arc OpenSim found, or the chord between its tangent points.
  double s0 = std::fabs(os.length);
  if (!(s0 > 0.0)) s0 = (S.Project(os.r2) - problem.c).norm();
  Eigen::Vector3d z(0.0, 0.0, std::max(s0, 1e-3 * scale));
  Eigen::Vector3d res = problem.Residual(z);
  bool converged = false;
  for (int it = 0; it < 30 && res.allFinite(); ++it) {
    if (res.norm() < 1e-13) {
      converged = true;
      break;
    }
    Eigen::Matrix3d J;
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-7 * scale;
      Eigen::Vector3d zp = z, zm = z;
      zp[k] += h;
      zm[k] -= h;
      J.col(k) = (problem.Residual(zp) - problem.Residual(zm)) / (2.0 * h);
    }
    Eigen::Vector3d dz = J.colPivHouseholderQr().solve(-res);
    if (!dz.allFinite()) break;
    // Damping: never move further than a tenth of the curvature radius per step.
    const double limit = 0.1 * scale;
    if (dz.norm() > limit) dz *= limit / dz.norm();
    double step = 1.0;
    Eigen::Vector3d trial = z + dz;
    Eigen::Vector3d trial_res = problem.Residual(trial);
    while (!(trial_res.norm() < res.norm()) && step > 1e-3) {
      step *= 0.5;
      trial = z + step * dz;
      trial_res = problem.Residual(trial);
    }
    if (!(trial_res.norm() < res.norm())) break;
    z = trial;
    res = trial_res;
    // Re-centre the chart on the new start point.
    problem.c = problem.Start(z);
    const V3 nc = S.Normal(problem.c);
    problem.e1 = nc.unitOrthogonal();
    problem.e2 = nc.cross(problem.e1);
    z.head<2>().setZero();
  }
  if (!converged && res.allFinite() && res.norm() < 1e-10) converged = true;
  V3 r1, r2;
  double ahead = 0.0;
  problem.Residual(z, &r1, &r2, &ahead);
  if (!converged || !(z[2] > 0.0) || !(ahead > 0.0) || !r1.allFinite() || !r2.allFinite()) {
    OsSegment out = Fallback(os);
    if (!converged) out.status |= kWrapNotConverged;
    return out;
  }
  OsSegment out = os;
  out.r1 = r1;
  out.r2 = r2;
  out.length = z[2];
  out.status &= ~kWrapNegativeArc;
  return out;
}

}  // namespace

OsSegment ExactSegment(const WrapSurface& surface, const V3& p1, const V3& p2,
                       const OsSegment& os) {
  if (!os.has_path || os.code < 2) return os;
  switch (surface.shape) {
    case WrapShape::kCylinder: return ExactCylinder(surface.radius, p1, p2, os);
    case WrapShape::kSphere: return ExactSphere(surface.radius, p1, p2, os);
    case WrapShape::kEllipsoid: {
      Implicit S{WrapShape::kEllipsoid, surface.radii, 0.0, 0.0, 0.0, 0.0};
      const double a = surface.radii.minCoeff(), b = surface.radii.maxCoeff();
      S.rho = a * a / b;
      S.size = b;
      return ExactGeodesic(S, p1, p2, os);
    }
    case WrapShape::kTorus: {
      Implicit S{WrapShape::kTorus,    V3::Zero(), surface.outer_radius,
                 surface.inner_radius, 0.0,        0.0};
      S.rho = std::min(surface.inner_radius, surface.outer_radius - surface.inner_radius);
      S.size = surface.outer_radius + surface.inner_radius;
      return ExactGeodesic(S, p1, p2, os);
    }
  }
  return os;
}

}  // namespace isowrench::wrap_impl
