// OpenSim 4.x's wrap algorithms, ported line by line from opensim-core
// (OpenSim/Simulation/Wrap/WrapMath.cpp, WrapCylinder.cpp, WrapSphere.cpp, WrapEllipsoid.cpp,
// WrapTorus.cpp; Apache-2.0). Each function says which one it follows. Everything is in the wrap
// object's frame S, as in WrapObject::wrapPathSegment.
//
// Where the original reads state left by the previous posture (PathWrap::getPreviousWrap): the
// WrapResult copy assignment sets `factor` to NaN (WrapResult.cpp), so the "previous" r1, r2 it
// hands to wrapLine are always NaN; the cylinder and the ellipsoid overwrite them before any
// use, and the sphere's one read of them (a segment through its centre) is a NaN length in
// OpenSim, replaced here by a defined fallback with kWrapDegenerate. Only the display sampling
// (wrap_pts between the tangent points) is not reproduced, except where it changes the length
// or the tangent points (WrapCylinder::_make_spiral_path's adjustment, the ellipsoid's polyline).

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "wrap/wrap_impl.hpp"

namespace isowrench::wrap_impl {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;                        // SimTK_PI
constexpr double kSimTKEps = std::numeric_limits<double>::epsilon();  // SimTK::Eps
constexpr double kRoundoffError = 0.0000000000002;                    // SimmMacros.h ROUNDOFF_ERROR
constexpr double kLineEpsilon = 0.00001;                              // WrapMath.cpp LINE_EPSILON

// SimmMacros.h
int Dsign(double a) { return a >= 0.0 ? 1 : -1; }
bool EqualWithinError(double a, double b) { return std::fabs(a - b) <= kRoundoffError; }

// ---- WrapMath (WrapMath.h / WrapMath.cpp) ----------------------------------------------------

double NormalizeOrZero(const V3& a, V3& r) {
  const double mag = a.norm();
  if (mag >= kSimTKEps) {
    r = a * (1.0 / mag);
  } else {
    r.setZero();
  }
  return mag;
}

double DistanceSquaredBetweenPoints(const V3& a, const V3& b) { return (a - b).squaredNorm(); }

double DistanceSquaredPointToLine(const V3& point, const V3& line_point, const V3& line) {
  const V3 p = line_point - point;
  const V3 n = line.normalized();
  return (p - p.dot(n) * n).squaredNorm();
}

double Det3(const Eigen::Matrix3d& m) { return m.determinant(); }

// WrapMath::IntersectLines: closest points of lines p1p2 and p3p4; false if parallel.
bool IntersectLines(const V3& p1, const V3& p2, const V3& p3, const V3& p4, V3& pInt1, double& s,
                    V3& pInt2, double& t) {
  V3 vec1 = p2 - p1;
  const double mag1 = NormalizeOrZero(vec1, vec1);
  V3 vec2 = p4 - p3;
  const double mag2 = NormalizeOrZero(vec2, vec2);
  const V3 cross_prod = vec1.cross(vec2);
  const double denom = cross_prod.squaredNorm();
  if (EqualWithinError(denom, 0.0)) {
    s = t = kNaN;
    return false;
  }
  Eigen::Matrix3d mat;
  mat.row(0) = (p3 - p1).transpose();
  mat.row(1) = vec1.transpose();
  mat.row(2) = cross_prod.transpose();
  t = Det3(mat) / denom;
  pInt2 = p3 + t * vec2;
  mat.row(1) = vec2.transpose();
  s = Det3(mat) / denom;
  pInt1 = p1 + s * vec1;
  s /= mag1;
  t /= mag2;
  return true;
}

// WrapMath::IntersectLineSegPlane.
bool IntersectLineSegPlane(const V3& pt1, const V3& pt2, const V3& plane, double d, V3& inter) {
  const V3 vec = pt2 - pt1;
  const double dotprod = vec.dot(plane);
  if (std::fabs(dotprod) < kLineEpsilon) return false;
  const double t = (-d - plane[0] * pt1[0] - plane[1] * pt1[1] - plane[2] * pt1[2]) / dotprod;
  if ((t < -kLineEpsilon) || (t > 1.0 + kLineEpsilon)) return false;
  inter = pt1 + t * vec;
  return true;
}

// WrapMath::GetClosestPointOnLineToPoint.
void ClosestPointOnLine(const V3& pt, const V3& line_pt, const V3& line, V3& closest, double& t) {
  V3 v1 = pt - line_pt;
  V3 v2 = line;
  const double mag = NormalizeOrZero(v1, v1);
  const double mag2 = NormalizeOrZero(v2, v2);
  t = v1.dot(v2) * mag;
  closest = line_pt + t * v2;
  t = t / mag2;
}

// SimTK::UnitVec3(v): v / |v| (NaN for a zero vector; callers guard).
V3 Unit(const V3& v) { return v / v.norm(); }

// ---- WrapCylinder ---------------------------------------------------------------------------

const V3 kCylP0(0.0, 0.0, -1.0);                          // WrapCylinder.cpp p0
const V3 kCylDn(0.0, 0.0, 1.0);                           // WrapCylinder.cpp dn
constexpr int kCylMaxIterations = 100;                    // MAX_ITERATIONS
constexpr double kTangencyThreshold = 0.1 * kPi / 180.0;  // TANGENCY_THRESHOLD

struct Cylinder {
  double radius;
  double length;
  int wrap_axis;
  int wrap_sign;

  // WrapCylinder::_adjust_tangent_point.
  static bool AdjustTangentPoint(const V3& pt1, const V3& dn, V3& r1, const V3& w1) {
    V3 pr_vec = r1 - pt1;
    V3 rw_vec = w1 - r1;
    NormalizeOrZero(pr_vec, pr_vec);
    NormalizeOrZero(rw_vec, rw_vec);
    const double alpha = std::acos(pr_vec.dot(dn));
    const double omega = std::acos(rw_vec.dot(dn));
    if (std::fabs(alpha - omega) > kTangencyThreshold) {
      V3 p1a, w1a, p1w1_int, p1aw1a_int;
      double t = 0, p1w1_t = 0, p1aw1a_t = 0;
      ClosestPointOnLine(pt1, r1, dn, p1a, t);
      ClosestPointOnLine(w1, r1, dn, w1a, t);
      IntersectLines(pt1, w1, p1a, w1a, p1w1_int, p1w1_t, p1aw1a_int, p1aw1a_t);
      r1 += 1.5 * (p1aw1a_int - r1);
      return true;
    }
    return false;
  }

  // WrapCylinder::_make_spiral_path: the length r theta (+ axial), after sliding r1/r2 along
  // the axis to tangency within 0.1 degree when the muscle has more than one wrap. The
  // adjustment runs on the second of the display samples (0.002 m apart), so it happens only
  // when the path is at least 4 mm long.
  void MakeSpiralPath(const V3& p1, const V3& p2, bool far_side_wrap, bool single_wrap,
                      OsSegment& w) const {
    const double sense = far_side_wrap ? -1.0 : 1.0;
    int iterations = 0;
    for (;;) {
      V3 r1a, r2a;
      double t = 0;
      ClosestPointOnLine(w.r1, kCylP0, kCylDn, r1a, t);
      ClosestPointOnLine(w.r2, kCylP0, kCylDn, r2a, t);
      const double axial_dist = (r2a - r1a).dot(kCylDn);
      const V3 uu = w.r1 - r1a;
      const V3 vv = w.r2 - r2a;
      double theta = std::atan2(uu.cross(vv).dot(kCylDn), uu.dot(vv));
      if (far_side_wrap) theta = 2.0 * kPi - theta;
      const double x = radius * theta;
      const double y = axial_dist;
      w.length = std::sqrt(x * x + y * y);
      w.sense = (sense * theta >= 0.0) ? 1 : -1;
      w.has_path = true;
      if (single_wrap) return;  // no adjustment (neither branch of the original adjusts)
      auto spiral_point = [&](double s) {
        return V3(Eigen::AngleAxisd(sense * s * theta, kCylDn) * w.r1 + kCylDn * (s * axial_dist));
      };
      // (int) of a NaN is undefined: a NaN length (degenerate tangent points) is not adjusted;
      // the caller turns it into no wrap.
      const double samples = w.length / 0.002;
      if (!(samples >= 2.0)) return;
      const int segments = samples > 1e6 ? 1000000 : static_cast<int>(samples);
      const double s = 1.0 / segments;  // i == 1
      const V3 wrap_pt = spiral_point(s);
      const V3 saved_r1 = w.r1, saved_r2 = w.r2;
      const bool adjusted_r1 = AdjustTangentPoint(p1, kCylDn, w.r1, wrap_pt);
      // (the original's spiral point lambda reads r1 by reference: the adjusted one)
      const V3 temp_wrap_pt = spiral_point(1.0 - s);
      const bool adjusted_r2 = AdjustTangentPoint(p2, kCylDn, w.r2, temp_wrap_pt);
      if (!(adjusted_r1 || adjusted_r2)) return;
      if (iterations >= kCylMaxIterations) {  // the original stops adjusting: keep this path
        w.r1 = saved_r1;
        w.r2 = saved_r2;
        w.status |= kWrapNotConverged;
        return;
      }
      ++iterations;
    }
  }

  // WrapCylinder::wrapLine.
  OsSegment WrapLine(const V3& aPoint1, const V3& aPoint2, bool single_wrap) const {
    OsSegment w;
    w.r1 = V3::Constant(kNaN);  // previousWrap.r1 * NaN factor
    w.r2 = V3::Constant(kNaN);
    const double r_squared = radius * radius;
    const bool constrained = wrap_sign != 0;
    bool far_side_wrap = false, long_wrap = false;
    int return_code = 2;  // wrapped
    w.flag = false;
    w.length = 0.0;
    if (DistanceSquaredPointToLine(aPoint1, kCylP0, kCylDn) < r_squared ||
        DistanceSquaredPointToLine(aPoint2, kCylP0, kCylDn) < r_squared) {
      w.code = 1;
      return w;
    }
    const V3 cylStart(0.0, 0.0, -0.5 * length);
    const V3 cylEnd(0.0, 0.0, 0.5 * length);
    V3 near12 = V3::Zero(), near00 = V3::Zero();
    double t12 = kNaN, t00 = kNaN;
    IntersectLines(aPoint1, aPoint2, cylStart, cylEnd, near12, t12, near00, t00);
    if (!constrained) {
      if (DistanceSquaredBetweenPoints(near12, near00) < r_squared && t12 > 0.0 && t12 < 1.0) {
        return_code = 3;
      } else {
        w.code = 0;
        return w;
      }
    }
    V3 p11, p22;
    double t = 0;
    ClosestPointOnLine(aPoint1, kCylP0, kCylDn, p11, t);
    ClosestPointOnLine(aPoint2, kCylP0, kCylDn, p22, t);
    V3 vv = aPoint1 - p11;
    const double p11_dist = NormalizeOrZero(vv, vv);
    double sin_theta = radius / p11_dist;
    double dist = radius * sin_theta;
    V3 pp = p11 + dist * vv;
    dist = std::sqrt(r_squared - dist * dist);
    V3 uu = kCylDn.cross(vv);
    V3 r1a = pp + dist * uu;
    V3 r1b = pp - dist * uu;
    vv = aPoint2 - p22;
    const double p22_dist = NormalizeOrZero(vv, vv);
    sin_theta = radius / p22_dist;
    dist = radius * sin_theta;
    pp = p22 + dist * vv;
    dist = std::sqrt(r_squared - dist * dist);
    uu = kCylDn.cross(vv);
    V3 r2a = pp + dist * uu;
    V3 r2b = pp - dist * uu;
    const int axis = wrap_axis;
    const int sign = wrap_sign;
    if (constrained) {
      if (Dsign(aPoint1[axis]) == sign || Dsign(aPoint2[axis]) == sign) {
        if (DistanceSquaredBetweenPoints(near12, near00) < r_squared && t12 > 0.0 && t12 < 1.0) {
          return_code = 3;
        } else {
          if (Dsign(aPoint1[axis]) != Dsign(aPoint2[axis]) && Dsign(near12[axis]) != sign) {
            return_code = 2;
          } else {
            w.code = 0;
            return w;
          }
        }
      }
      const V3 r1am = r1a - p11, r1bm = r1b - p11, r2am = r2a - p22, r2bm = r2b - p22;
      const double alpha = std::acos(r1am.dot(r2bm) / (r1am.norm() * r2bm.norm()));
      const double beta = std::acos(r1bm.dot(r2am) / (r1bm.norm() * r2am.norm()));
      if (Dsign(r1a[axis]) == sign && Dsign(r1b[axis]) == sign) {
        if (Dsign(r2a[axis]) == sign) {
          w.r1 = r1b;
          w.r2 = r2a;
          far_side_wrap = !(alpha > beta);
        } else {
          w.r1 = r1a;
          w.r2 = r2b;
          far_side_wrap = alpha > beta;
        }
      } else if (Dsign(r1a[axis]) == sign && Dsign(r1b[axis]) != sign) {
        w.r1 = r1a;
        w.r2 = r2b;
        far_side_wrap = alpha > beta;
      } else if (Dsign(r1a[axis]) != sign && Dsign(r1b[axis]) == sign) {
        w.r1 = r1b;
        w.r2 = r2a;
        far_side_wrap = !(alpha > beta);
      } else {
        if (Dsign(r2a[axis]) == sign) {
          w.r1 = r1b;
          w.r2 = r2a;
          far_side_wrap = !(alpha > beta);
        } else if (Dsign(r2b[axis]) == sign) {
          w.r1 = r1a;
          w.r2 = r2b;
          far_side_wrap = alpha > beta;
        } else {  // none of the four tangent points is on the active portion
          if (alpha > beta) {
            w.r1 = r1a;
            w.r2 = r2b;
          } else {
            w.r1 = r1b;
            w.r2 = r2a;
          }
          far_side_wrap = true;
        }
      }
      const V3 sum_musc = (w.r1 - aPoint1) + (w.r2 - aPoint2);
      const V3 sum_r = (w.r1 - p11) + (w.r2 - p22);
      if (sum_r.dot(sum_musc) < 0.0) long_wrap = true;
    } else {
      V3 r1am = r1a - p11, r1bm = r1b - p11, r2am = r2a - p22, r2bm = r2b - p22;
      NormalizeOrZero(r1am, r1am);
      NormalizeOrZero(r1bm, r1bm);
      NormalizeOrZero(r2am, r2am);
      NormalizeOrZero(r2bm, r2bm);
      const double dot1 = r1am.dot(r2am), dot2 = r1am.dot(r2bm), dot3 = r1bm.dot(r2am),
                   dot4 = r1bm.dot(r2bm);
      if (dot1 > dot2 && dot1 > dot3 && dot1 > dot4) {
        w.r1 = r1a;
        w.r2 = r2a;
      } else if (dot2 > dot3 && dot2 > dot4) {
        w.r1 = r1a;
        w.r2 = r2b;
      } else if (dot3 > dot4) {
        w.r1 = r1b;
        w.r2 = r2a;
      } else {
        w.r1 = r1b;
        w.r2 = r2b;
      }
    }
    // Bisect the angle between r1 and r2 to find the apex edge of the cylinder.
    uu = w.r1 - p11;
    vv = w.r2 - p22;
    vv = uu + vv;
    NormalizeOrZero(vv, vv);
    t = p11_dist / (p11_dist + p22_dist);
    const V3 mpt = aPoint1 + t * (aPoint2 - aPoint1);
    V3 axispt;
    ClosestPointOnLine(mpt, kCylP0, kCylDn, axispt, t);
    V3 l1 = aPoint1 - axispt;
    V3 l2 = aPoint2 - axispt;
    NormalizeOrZero(l1, l1);
    NormalizeOrZero(l2, l2);
    V3 plane_normal = Unit(l1.cross(l2));
    NormalizeOrZero(plane_normal, plane_normal);
    V3 vert1 = kCylDn.cross(plane_normal);
    NormalizeOrZero(vert1, vert1);
    V3 vert2 = plane_normal.cross(kCylDn);
    NormalizeOrZero(vert2, vert2);
    const V3 apex1 = axispt + radius * vert1;
    const V3 apex2 = axispt + radius * vert2;
    const double dist1 = DistanceSquaredBetweenPoints(mpt, apex1);
    const double dist2 = DistanceSquaredBetweenPoints(mpt, apex2);
    V3 apex;
    if (far_side_wrap) {
      apex = dist1 < dist2 ? apex2 : apex1;
    } else {
      apex = dist1 < dist2 ? apex1 : apex2;
    }
    // Slide r1/r2 along their edge of tangency: intersect with the plane p1, p2, apex.
    uu = aPoint1 - apex;
    vv = aPoint2 - apex;
    NormalizeOrZero(uu, uu);
    NormalizeOrZero(vv, vv);
    plane_normal = Unit(uu.cross(vv));
    const double d =
        -aPoint1[0] * plane_normal[0] - aPoint1[1] * plane_normal[1] - aPoint1[2] * plane_normal[2];
    r1a = w.r1 - 10.0 * kCylDn;
    r2a = w.r2 - 10.0 * kCylDn;
    r1b = w.r1 + 10.0 * kCylDn;
    r2b = w.r2 + 10.0 * kCylDn;
    V3 r1p, r2p;
    const bool r1_inter = IntersectLineSegPlane(r1a, r1b, plane_normal, d, r1p);
    const bool r2_inter = IntersectLineSegPlane(r2a, r2b, plane_normal, d, r2p);
    if (r1_inter) {
      ClosestPointOnLine(r1p, p11, p22, r1a, t);
      if (DistanceSquaredBetweenPoints(r1a, p22) < DistanceSquaredBetweenPoints(p11, p22)) {
        w.r1 = r1p;
      }
    }
    if (r2_inter) {
      ClosestPointOnLine(r2p, p11, p22, r2a, t);
      if (DistanceSquaredBetweenPoints(r2a, p11) < DistanceSquaredBetweenPoints(p22, p11)) {
        w.r2 = r2p;
      }
    }
    // Both tangent points beyond the cylinder's length: no wrap.
    const double halfL = length / 2.0;
    if ((w.r1[2] < -halfL || w.r1[2] > halfL) && (w.r2[2] < -halfL || w.r2[2] > halfL)) {
      w.code = 0;
      return w;
    }
    MakeSpiralPath(aPoint1, aPoint2, long_wrap, single_wrap, w);
    w.far_side = long_wrap;
    w.flag = true;
    w.code = return_code;
    return w;
  }
};

// ---- WrapSphere -----------------------------------------------------------------------------

// WrapSphere::wrapLine. `fallback_plane`: the plane normal used when the line passes through the
// centre (OpenSim reads the NaN previous result there: kWrapDegenerate).
OsSegment SphereWrapLine(double radius, int wrap_axis, int wrap_sign, const V3& aPoint1,
                         const V3& aPoint2) {
  OsSegment w;
  w.r1 = V3::Constant(kNaN);
  w.r2 = V3::Constant(kNaN);
  int return_code = 2;
  bool far_side_wrap = false;
  const V3 origin = V3::Zero();
  w.flag = true;
  const V3 p1m = aPoint1 - origin;
  const V3 p2m = aPoint2 - origin;  // (the original subtracts origin[1]: zero either way)
  const V3 ri = aPoint1 - aPoint2;
  const V3 mp = origin - aPoint2;
  V3 p1p2 = aPoint1 - aPoint2;
  if (p1m.norm() < radius || p2m.norm() < radius) {
    w.code = 1;
    return w;
  }
  const double a = ri.dot(ri);
  const double b = -2.0 * mp.dot(ri);
  const double c = mp.dot(mp) - radius * radius;
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) {
    w.flag = false;
    w.code = 0;
    return w;
  }
  const double l1 = (-b + std::sqrt(disc)) / (2.0 * a);
  const double l2 = (-b - std::sqrt(disc)) / (2.0 * a);
  if (!(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0) || l1 < l2) {
    w.flag = false;
    w.code = 0;
    return w;
  }
  NormalizeOrZero(p1p2, p1p2);
  V3 np2;
  NormalizeOrZero(p2m, np2);
  V3 hp2 = p1p2.cross(np2);
  V3 n;
  if (hp2.norm() < 0.00001) {
    // OpenSim: "goto calc_path" with the previous r1, r2 (NaN): a NaN length. Here: the plane
    // through the segment and the coordinate axis most perpendicular to it.
    w.status |= kWrapDegenerate;
    Eigen::Index k = 0;
    p1p2.cwiseAbs().minCoeff(&k);
    hp2 = p1p2.cross(V3::Unit(k));
  }
  NormalizeOrZero(hp2, n);
  V3 r1a, r1b, r2a, r2b;
  auto candidates = [&](const V3& p, V3& ra_out, V3& rb_out) {
    V3 y = origin - p;
    NormalizeOrZero(y, y);
    const V3 z = n.cross(y);
    const double pm = (p - origin).norm();
    const double angle = std::asin(radius / pm);
    // aa = ra * ~Rx(angle); column 1 of aa = cos(angle) y - sin(angle) z.
    const V3 col_a = std::cos(angle) * y - std::sin(angle) * z;
    const V3 col_b = std::cos(-angle) * y - std::sin(-angle) * z;
    ra_out = p + col_a * pm * std::cos(angle);
    rb_out = p + col_b * pm * std::cos(angle);
  };
  candidates(aPoint1, r1a, r1b);
  candidates(aPoint2, r2a, r2b);
  V3 r1am = r1a - origin, r1bm = r1b - origin, r2am = r2a - origin, r2bm = r2b - origin;
  NormalizeOrZero(r1am, r1am);
  NormalizeOrZero(r1bm, r1bm);
  NormalizeOrZero(r2am, r2am);
  NormalizeOrZero(r2bm, r2bm);
  const V3* r11;
  const V3* r22;
  {
    const double j1 = r1am.dot(r2am), j2 = r1am.dot(r2bm), j3 = r1bm.dot(r2am), j4 = r1bm.dot(r2bm);
    if (j1 > j2 && j1 > j3 && j1 > j4) {
      w.r1 = r1a;
      w.r2 = r2a;
      r11 = &r1b;
      r22 = &r2b;
    } else if (j2 > j3 && j2 > j4) {
      w.r1 = r1a;
      w.r2 = r2b;
      r11 = &r1b;
      r22 = &r2a;
    } else if (j3 > j4) {
      w.r1 = r1b;
      w.r2 = r2a;
      r11 = &r1a;
      r22 = &r2b;
    } else {
      w.r1 = r1b;
      w.r2 = r2b;
      r11 = &r1a;
      r22 = &r2a;
    }
  }
  if (wrap_sign != 0) {
    const int axis = wrap_axis;
    const int sign = wrap_sign;
    if (Dsign(aPoint1[axis]) == sign || Dsign(aPoint2[axis]) == sign) {
      const double r_squared = radius * radius;
      V3 mm;
      double tt = 0;
      ClosestPointOnLine(origin, aPoint1, p1p2, mm, tt);
      tt = -tt;  // because p1p2 is actually aPoint2->aPoint1
      if (DistanceSquaredBetweenPoints(origin, mm) < r_squared && tt > 0.0 && tt < 1.0) {
        return_code = 3;
      } else {
        if (Dsign(aPoint1[axis]) != Dsign(aPoint2[axis]) && Dsign(mm[axis]) != sign) {
          return_code = 2;
        } else {
          w.code = 0;
          return w;
        }
      }
    }
    if (Dsign(aPoint1[axis]) != sign || Dsign(aPoint2[axis]) != sign) {
      V3 wrapaxis = V3::Zero();
      wrapaxis[axis] = sign;
      V3 sum_musc = (origin - aPoint1) + (origin - aPoint2);
      NormalizeOrZero(sum_musc, sum_musc);
      if (r1am.dot(sum_musc) > r1bm.dot(sum_musc)) {
        w.r1 = r1a;
        r11 = &r1b;
      } else {
        w.r1 = r1b;
        r11 = &r1a;
      }
      if (r2am.dot(sum_musc) > r2bm.dot(sum_musc)) {
        w.r2 = r2a;
        r22 = &r2b;
      } else {
        w.r2 = r2b;
        r22 = &r2a;
      }
      sum_musc = (w.r1 - aPoint1) + (w.r2 - aPoint2);
      NormalizeOrZero(sum_musc, sum_musc);
      if (sum_musc.dot(wrapaxis) < 0.0) {
        w.r1 = *r11;
        w.r2 = *r22;
      }
      sum_musc = (w.r1 - aPoint1) + (w.r2 - aPoint2);
      const V3 sum_r = (w.r1 - origin) + (w.r2 - origin);
      if (sum_r.dot(sum_musc) < 0.0) far_side_wrap = true;
    }
  }
  // calc_path:
  V3 r1n, r2n;
  NormalizeOrZero(w.r1 - origin, r1n);
  NormalizeOrZero(w.r2 - origin, r2n);
  double cosine = r1n.dot(r2n);
  if (std::fabs(cosine) > 1.0) {  // acos would give NaN
    w.status |= kWrapDegenerate;
    cosine = std::clamp(cosine, -1.0, 1.0);
  }
  double angle = std::acos(cosine);
  if (far_side_wrap) {
    angle = -(2 * kPi - angle);
    w.status |= kWrapNegativeArc;
  }
  w.length = radius * angle;
  w.far_side = far_side_wrap;
  w.plane_normal = n;
  w.has_path = true;  // wrap_pts holds r1 ... r2
  w.code = return_code;
  return w;
}

// ---- WrapEllipsoid --------------------------------------------------------------------------

constexpr double kEllipsoidTiny = 0.00000001;  // ELLIPSOID_TINY
constexpr double kMuBlendMin = 0.7073;         // MU_BLEND_MIN
constexpr double kMuBlendMax = 0.9;            // MU_BLEND_MAX
constexpr int kNumFanSamples = 300;            // NUM_FAN_SAMPLES
constexpr double kSvBoundaryBlend = 0.3;       // SV_BOUNDARY_BLEND

struct Ellipsoid {
  V3 dims;  // get_dimensions(), unscaled (used by findClosestPoint's special case)
  int wrap_axis;
  int wrap_sign;
  mutable unsigned status = 0;

  // WrapEllipsoid::closestPointToEllipse (Graphics Gems IV).
  double ClosestPointToEllipse(double a, double b, double u, double v, double* x, double* y) const {
    const double a2 = a * a, b2 = b * b;
    const double u2 = u * u, v2 = v * v;
    const double a2u2 = a2 * u2, b2v2 = b2 * v2;
    double dx, dy, xda, ydb;
    double t, P = 0, Q = 0, P2, Q2, f, fp;
    const bool nearXOrigin = EqualWithinError(0.0, u);
    const bool nearYOrigin = EqualWithinError(0.0, v);
    if (nearXOrigin && nearYOrigin) {
      if (a < b) {
        *x = (u < 0.0 ? -a : a);
        *y = v;
        return a;
      } else {
        *x = u;
        *y = (v < 0.0 ? -b : b);
        return b;
      }
    }
    if (nearXOrigin) {
      if (a >= b || std::fabs(v) >= b - a2 / b) {
        *x = u;
        *y = (v >= 0 ? b : -b);
        dy = *y - v;
        return std::fabs(dy);
      } else {
        *y = b2 * v / (b2 - a2);
        dy = *y - v;
        ydb = *y / b;
        *x = a * std::sqrt(std::fabs(1 - ydb * ydb));
        return std::sqrt(*x * *x + dy * dy);
      }
    }
    if (nearYOrigin) {
      if (b >= a || std::fabs(u) >= a - b2 / a) {
        *x = (u >= 0 ? a : -a);
        *y = v;
        return std::fabs(*x - u);
      } else {
        *x = a2 * u / (a2 - b2);
        dx = *x - u;
        xda = *x / a;
        *y = b * std::sqrt(std::fabs(1 - xda * xda));
        return std::sqrt(dx * dx + *y * *y);
      }
    }
    if ((u / a) * (u / a) + (v / b) * (v / b) < 1.0) {
      t = 0.0;
    } else {
      const double max = std::max(a, b);
      t = max * std::sqrt(u * u + v * v);
    }
    int i = 0;
    for (; i < 64; i++) {
      P = t + a2;
      P2 = P * P;
      Q = t + b2;
      Q2 = Q * Q;
      f = P2 * Q2 - a2u2 * Q2 - b2v2 * P2;
      if (std::fabs(f) < 1e-09) break;
      fp = 2.0 * (P * Q * (P + Q) - a2u2 * Q - b2v2 * P);
      t -= f / fp;
    }
    if (i == 64) status |= kWrapNotConverged;
    *x = a2 * u / P;
    *y = b2 * v / Q;
    dx = *x - u;
    dy = *y - v;
    (void)u2;
    (void)v2;
    return std::sqrt(dx * dx + dy * dy);
  }

  // WrapEllipsoid::findClosestPoint. On failure (64 Newton steps) the outputs keep their values
  // and -1 is returned, as in the original.
  double FindClosestPoint(double a, double b, double c, double u, double v, double w, double* x,
                          double* y, double* z, int specialCaseAxis = -1) const {
    if (specialCaseAxis < 0) {
      const double uvw[3] = {u, v, w};
      double minEllipseRadiiSum = std::numeric_limits<double>::infinity();
      for (int i = 0; i < 3; i++) {
        if (EqualWithinError(0.0, uvw[i])) {
          double ellipseRadiiSum = 0;
          for (int j = 0; j < 3; j++)
            if (j != i) ellipseRadiiSum += dims[j];
          if (minEllipseRadiiSum > ellipseRadiiSum) {
            specialCaseAxis = i;
            minEllipseRadiiSum = ellipseRadiiSum;
          }
        }
      }
    }
    if (specialCaseAxis == 0) {
      *x = u;
      return ClosestPointToEllipse(b, c, v, w, y, z);
    }
    if (specialCaseAxis == 1) {
      *y = v;
      return ClosestPointToEllipse(c, a, w, u, z, x);
    }
    if (specialCaseAxis == 2) {
      *z = w;
      return ClosestPointToEllipse(a, b, u, v, x, y);
    }
    const double a2 = a * a, b2 = b * b, c2 = c * c;
    const double u2 = u * u, v2 = v * v, w2 = w * w;
    const double a2u2 = a2 * u2, b2v2 = b2 * v2, c2w2 = c2 * w2;
    double t;
    if ((u / a) * (u / a) + (v / b) * (v / b) + (w / c) * (w / c) < 1.0) {
      t = 0.0;
    } else {
      const double max = std::max({a, b, c});
      t = max * std::sqrt(u * u + v * v + w * w);
    }
    for (int i = 0; i < 64; i++) {
      const double P = t + a2, P2 = P * P;
      const double Q = t + b2, Q2 = Q * Q;
      const double R = t + c2, R2 = R * R;
      const double f = P2 * Q2 * R2 - a2u2 * Q2 * R2 - b2v2 * P2 * R2 - c2w2 * P2 * Q2;
      if (std::fabs(f) < 1e-09) {
        *x = a2 * u / P;
        *y = b2 * v / Q;
        *z = c2 * w / R;
        const double dx = *x - u, dy = *y - v, dz = *z - w;
        return std::sqrt(dx * dx + dy * dy + dz * dz);
      }
      const double PQ = P * Q, PR = P * R, QR = Q * R, PQR = P * Q * R;
      const double fp = 2.0 * (PQR * (QR + PR + PQ) - a2u2 * QR * (Q + R) - b2v2 * PR * (P + R) -
                               c2w2 * PQ * (P + Q));
      t -= f / fp;
    }
    status |= kWrapNotConverged;
    return -1.0;
  }

  // WrapEllipsoid::calcTangentPoint: Levenberg-Marquardt-like solve putting r1 in the plane
  // (vs, vs4) with the line r1 -> p1 tangent.
  void CalcTangentPoint(double p1e, V3& r1, const V3& p1, const V3& m, const V3& a, const V3& vs,
                        double vs4) const {
    const int maxit = 50, maxit2 = 1000;
    double alpha = 0.01;
    if (std::fabs(p1e) < 0.0001) {
      r1 = p1;
      return;
    }
    V3 nr1;
    auto sq = [](double x) { return x * x; };
    for (int i = 0; i < 3; i++) nr1[i] = 2.0 * (r1[i] - m[i]) / sq(a[i]);
    double d1 = -nr1.dot(r1);
    double ee[4];
    auto residuals = [&]() {
      ee[0] = vs.dot(r1) + vs4;
      ee[1] = -1.0;
      for (int i = 0; i < 3; i++) ee[1] += sq((r1[i] - m[i]) / a[i]);
      ee[2] = nr1.dot(r1) + d1;
      ee[3] = nr1.dot(p1) + d1;
      return sq(ee[0]) + sq(ee[1]) + sq(ee[2]) + sq(ee[3]);
    };
    double ssqo = residuals();
    double ssq = ssqo;
    int nit = 0;
    Eigen::Matrix4d dedth, dedth2;
    double v[4], diag[4], vt[4] = {0, 0, 0, 0};
    while ((ssq > kEllipsoidTiny) && (nit < maxit)) {
      nit++;
      for (int i = 0; i < 3; i++) {
        dedth(i, 0) = vs[i];
        dedth(i, 1) = 2.0 * (r1[i] - m[i]) / sq(a[i]);
        dedth(i, 2) = 2.0 * (2.0 * r1[i] - m[i]) / sq(a[i]);
        dedth(i, 3) = 2.0 * p1[i] / sq(a[i]);
      }
      dedth(3, 0) = 0.0;
      dedth(3, 1) = 0.0;
      dedth(3, 2) = 1.0;
      dedth(3, 3) = 1.0;
      V3 p1r1 = p1 - r1;
      NormalizeOrZero(p1r1, p1r1);
      V3 p1m = p1 - m;
      NormalizeOrZero(p1m, p1m);
      const double pcos = p1r1.dot(p1m);
      const double dd = pcos > 0.1 ? 1.0 - std::pow(pcos, 100) : 1.0;
      for (int i = 0; i < 4; i++) {
        v[i] = 0.0;
        for (int j = 0; j < 4; j++) v[i] -= dedth(i, j) * ee[j];
      }
      for (int i = 0; i < 4; i++) {
        for (int j = 0; j < 4; j++) {
          dedth2(i, j) = 0.0;
          for (int k = 0; k < 4; k++) dedth2(i, j) += dedth(i, k) * dedth(j, k);
        }
      }
      for (int i = 0; i < 4; i++) diag[i] = dedth2(i, i);
      int nit2 = 0;
      while ((ssq >= ssqo) && (nit2 < maxit2)) {
        for (int i = 0; i < 4; i++) dedth2(i, i) = diag[i] * (1.0 + alpha);
        const Eigen::Matrix4d ddinv2 = dedth2.inverse();
        for (int i = 0; i < 4; i++) {
          vt[i] = 0.0;
          for (int j = 0; j < 4; j++) vt[i] += dd * ddinv2(i, j) * v[j] / 16.0;
        }
        for (int i = 0; i < 3; i++) r1[i] += vt[i];
        d1 += vt[3];
        for (int i = 0; i < 3; i++) nr1[i] = 2.0 * (r1[i] - m[i]) / sq(a[i]);
        ssqo = ssq;
        ssq = residuals();
        alpha *= 4.0;
        nit2++;
      }
      alpha /= 8.0;
      double fakt = 0.5;
      nit2 = 0;
      while ((ssq <= ssqo) && (nit2 < maxit2)) {
        fakt *= 2.0;
        for (int i = 0; i < 3; i++) r1[i] += vt[i] * fakt;
        d1 += vt[3] * fakt;
        for (int i = 0; i < 3; i++) nr1[i] = 2.0 * (r1[i] - m[i]) / sq(a[i]);
        ssqo = ssq;
        ssq = residuals();
        nit2++;
      }
      for (int i = 0; i < 3; i++) r1[i] -= vt[i] * fakt;
      d1 -= vt[3] * fakt;
      for (int i = 0; i < 3; i++) nr1[i] = 2.0 * (r1[i] - m[i]) / sq(a[i]);
      ssq = residuals();
      ssqo = ssq;
    }
    if (ssq > kEllipsoidTiny) status |= kWrapNotConverged;
  }

  // WrapEllipsoid::CalcDistanceOnEllipsoid: the length of a polyline of up to 499 chords of
  // about 1 mm over the plane section (vs, vs4) from r1 to r2 (normalized units; the caller
  // divides by factor). Also returns the first and last interior points (for the wrong-way
  // test of wrapLine) and their count.
  double CalcDistanceOnEllipsoid(const V3& r1, const V3& r2, const V3& m, const V3& a, const V3& vs,
                                 double vs4, bool far_side_wrap, double factor, V3& w1, V3& w2,
                                 int& num_pts) const {
    const double desiredSegLength = 0.001;
    const V3 dr = r1 - r2;
    const double len = dr.norm() / factor;
    if (len < desiredSegLength) {
      num_pts = 2;
      w1 = r2;
      w2 = r1;
      return len * factor;
    }
    if (!std::isfinite(len)) {  // (int) of a NaN is undefined; the caller makes it no wrap
      status |= kWrapDegenerate;
      num_pts = 0;
      return len;
    }
    int numPathSegments =
        len / desiredSegLength > 499.0 ? 499 : static_cast<int>(len / desiredSegLength);
    if (numPathSegments <= 0) {
      num_pts = 0;
      return len;
    }
    if (numPathSegments > 499) numPathSegments = 499;
    const int numPathPts = numPathSegments + 1;
    const int numInteriorPts = numPathPts - 2;
    const V3 ux(1.0, 0.0, 0.0);
    int imax = 0;
    for (int i = 1; i < 3; i++)
      if (std::fabs(vs[i]) > std::fabs(vs[imax])) imax = i;
    V3 u = V3::Zero();
    u[imax] = 1.0;
    const double mu = (-vs.dot(m) - vs4) / vs.dot(u);
    const V3 a0 = m + mu * u;
    V3 ar1 = r1 - a0;
    NormalizeOrZero(ar1, ar1);
    V3 ar2 = r2 - a0;
    NormalizeOrZero(ar2, ar2);
    double cosine = ar1.dot(ar2);
    if (std::fabs(cosine) > 1.0) {
      status |= kWrapDegenerate;
      cosine = std::clamp(cosine, -1.0, 1.0);
    }
    const double phi0 = std::acos(cosine);
    const double dphi =
        far_side_wrap ? -(2 * kPi - phi0) / numPathSegments : phi0 / numPathSegments;
    V3 vsz = ar1.cross(ar2);
    NormalizeOrZero(vsz, vsz);
    const V3 vsy = vsz.cross(ar1);
    Eigen::Matrix3d r0;
    r0.col(0) = ar1;
    r0.col(1) = vsy;
    r0.col(2) = vsz;
    double total = 0.0;
    V3 previous = r1;
    for (int i = 0; i < numInteriorPts; i++) {
      const double phi = (i + 1) * dphi;
      Eigen::Matrix3d rphi = Eigen::Matrix3d::Zero();
      rphi(2, 2) = 1;
      rphi(0, 0) = std::cos(phi);
      rphi(0, 1) = -std::sin(phi);
      rphi(1, 0) = std::sin(phi);
      rphi(1, 1) = std::cos(phi);
      const V3 r = r0 * (rphi * ux);
      const V3 f1 = r.cwiseQuotient(a);
      const V3 f2 = (a0 - m).cwiseQuotient(a);
      const double aa = f1.dot(f1);
      const double bb = 2.0 * f1.dot(f2);
      const double cc = f2.dot(f2) - 1.0;
      double disc = bb * bb - 4.0 * aa * cc;
      if (!(disc >= 0.0)) {  // the ray from a0 misses the ellipsoid: NaN in OpenSim
        status |= kWrapDegenerate;
        disc = 0.0;
      }
      const double mu3 = (-bb + std::sqrt(disc)) / (2.0 * aa);
      const V3 s = a0 + mu3 * r;
      if (i == 0) w1 = s;
      if (i == numInteriorPts - 1) w2 = s;
      total += (s - previous).norm();
      previous = s;
    }
    total += (r2 - previous).norm();
    num_pts = numPathPts;
    if (numInteriorPts == 0) {
      w1 = r2;
      w2 = r1;
    }
    return total;
  }

  // WrapEllipsoid::wrapLine.
  OsSegment WrapLine(WrapMethod method, const V3& aPoint1, const V3& aPoint2) const {
    OsSegment w;
    auto sq = [](double x) { return x * x; };
    const V3 origin = V3::Zero();
    w.flag = true;
    const double factor = 3.0 / dims.sum();
    const V3 p1 = aPoint1 * factor;
    const V3 p2 = aPoint2 * factor;
    const V3 m = origin * factor;
    const V3 a = dims * factor;
    double p1e = -1.0, p2e = -1.0;
    for (int i = 0; i < 3; i++) {
      p1e += sq((p1[i] - m[i]) / a[i]);
      p2e += sq((p2[i] - m[i]) / a[i]);
    }
    if (p1e < -0.0001 || p2e < -0.0001) {
      w.flag = false;
      w.code = 1;
      return w;
    }
    V3 p1p2 = p1 - p2;
    V3 p1m = p1 - m;
    NormalizeOrZero(p1m, p1m);
    V3 p2m = p2 - m;
    NormalizeOrZero(p2m, p2m);
    const double ppm = p1m.dot(p2m) - 1.0;
    if (std::fabs(ppm) < 0.0001) {
      w.flag = false;
      w.code = 0;
      return w;
    }
    const V3 f1 = p1p2.cwiseQuotient(a);
    const V3 f2 = (p2 - m).cwiseQuotient(a);
    const double aa = f1.dot(f1);
    const double bb = 2.0 * f1.dot(f2);
    const double cc = f2.dot(f2) - 1.0;
    const double disc = sq(bb) - 4.0 * aa * cc;
    if (disc < 0.0) {
      w.flag = false;
      w.code = 0;
      return w;
    }
    const double l1 = (-bb + std::sqrt(disc)) / (2.0 * aa);
    const double l2 = (-bb - std::sqrt(disc)) / (2.0 * aa);
    if (!(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0)) {
      w.flag = false;
      w.code = 0;
      return w;
    }
    V3 r1 = p2 + l1 * p1p2;
    V3 r2 = p2 + l2 * p1p2;
    V3 c1 = V3::Constant(kNaN), sv = V3::Constant(kNaN);  // previousWrap.c1 / sv
    double fanWeight = -std::numeric_limits<double>::infinity();
    // ==== COMPUTE WRAPPING PLANE ====
    const V3 r1r2 = r2 - r1;
    V3 mu;
    NormalizeOrZero(p1p2, mu);
    double t[3];
    double t_sv[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    double t_c1[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (int i = 0; i < 3; i++) {
      mu[i] = std::fabs(mu[i]);
      t[i] = (m[i] - r1[i]) / r1r2[i];
      for (int j = 0; j < 3; j++) t_sv[i][j] = r1[j] + t[i] * r1r2[j];
      // (a NaN t for an axis the segment does not cross leaves t_c1[i] as it was: unused then)
      const unsigned saved = status;
      FindClosestPoint(a[0], a[1], a[2], t_sv[i][0], t_sv[i][1], t_sv[i][2], &t_c1[i][0],
                       &t_c1[i][1], &t_c1[i][2], i);
      if (!std::isfinite(t[i])) status = saved;
    }
    int bestMu = 0;
    for (int i = 1; i < 3; i++)
      if (mu[i] > mu[bestMu]) bestMu = i;
    if (method == WrapMethod::kHybrid || method == WrapMethod::kAxial) {
      if (method == WrapMethod::kHybrid && mu[bestMu] > kMuBlendMin) {
        double s = 1.0;
        if (t[bestMu] < 0.0 || t[bestMu] > 1.0)
          s = 0.0;
        else if (t[bestMu] < kSvBoundaryBlend)
          s = t[bestMu] / kSvBoundaryBlend;
        else if (t[bestMu] > (1.0 - kSvBoundaryBlend))
          s = (1.0 - t[bestMu]) / kSvBoundaryBlend;
        if (s < 1.0) mu[bestMu] = kMuBlendMin + s * (mu[bestMu] - kMuBlendMin);
      }
      if (method == WrapMethod::kAxial || mu[bestMu] > kMuBlendMin) {
        for (int i = 0; i < 3; i++) {
          c1[i] = t_c1[bestMu][i];
          sv[i] = t_sv[bestMu][i];
        }
      }
      if (method == WrapMethod::kHybrid && mu[bestMu] < kMuBlendMax) {
        V3 v_sum = V3::Zero();
        for (int i = 0; i < 3; i++) t_sv[2][i] = r1[i] + 0.5 * r1r2[i];
        for (int i = 1; i < kNumFanSamples - 1; i++) {
          const double tt = static_cast<double>(i) / kNumFanSamples;
          for (int j = 0; j < 3; j++) t_sv[0][j] = r1[j] + tt * r1r2[j];
          FindClosestPoint(a[0], a[1], a[2], t_sv[0][0], t_sv[0][1], t_sv[0][2], &t_c1[0][0],
                           &t_c1[0][1], &t_c1[0][2]);
          V3 v(t_c1[0][0] - t_sv[0][0], t_c1[0][1] - t_sv[0][1], t_c1[0][2] - t_sv[0][2]);
          NormalizeOrZero(v, v);
          v_sum += v;
        }
        NormalizeOrZero(v_sum, v_sum);
        for (int i = 0; i < 3; i++) t_c1[0][i] = t_sv[2][i] + v_sum[i];
        if (mu[bestMu] <= kMuBlendMin) {
          FindClosestPoint(a[0], a[1], a[2], t_c1[0][0], t_c1[0][1], t_c1[0][2], &c1[0], &c1[1],
                           &c1[2]);
          for (int i = 0; i < 3; i++) sv[i] = t_sv[2][i];
          fanWeight = 1.0;
        } else {
          const double tt = (mu[bestMu] - kMuBlendMin) / (kMuBlendMax - kMuBlendMin);
          const double oneMinusT = 1.0 - tt;
          FindClosestPoint(a[0], a[1], a[2], t_c1[0][0], t_c1[0][1], t_c1[0][2], &t_c1[1][0],
                           &t_c1[1][1], &t_c1[1][2]);
          for (int i = 0; i < 3; i++) {
            t_c1[2][i] = tt * c1[i] + oneMinusT * t_c1[1][i];
            sv[i] = tt * sv[i] + oneMinusT * t_sv[2][i];
          }
          FindClosestPoint(a[0], a[1], a[2], t_c1[2][0], t_c1[2][1], t_c1[2][2], &c1[0], &c1[1],
                           &c1[2]);
          fanWeight = oneMinusT;
        }
      }
    } else {  // midpoint
      sv = r1 + 0.5 * (r2 - r1);
      FindClosestPoint(a[0], a[1], a[2], sv[0], sv[1], sv[2], &c1[0], &c1[1], &c1[2]);
    }
    {
      bool use_c1_to_find_tangent_pts = true;
      if (method == WrapMethod::kAxial)
        use_c1_to_find_tangent_pts = (t[bestMu] > 0.0 && t[bestMu] < 1.0);
      if (use_c1_to_find_tangent_pts) r1 = r2 = c1;
    }
    if (wrap_sign != 0) {
      const double dist = c1[wrap_axis] - m[wrap_axis];
      if (Dsign(dist) != wrap_sign) {
        const V3 orig_c1 = c1;
        c1[wrap_axis] = -c1[wrap_axis];
        r1 = r2 = c1;
        if (EqualWithinError(fanWeight, -std::numeric_limits<double>::infinity()))
          fanWeight = 1.0 - (mu[bestMu] - kMuBlendMin) / (kMuBlendMax - kMuBlendMin);
        if (fanWeight > 1.0) fanWeight = 1.0;
        if (fanWeight > 0.0) {
          const double bisection = (orig_c1[wrap_axis] + c1[wrap_axis]) / 2.0;
          c1[wrap_axis] = c1[wrap_axis] + fanWeight * (bisection - c1[wrap_axis]);
          const V3 tc1 = c1;
          FindClosestPoint(a[0], a[1], a[2], tc1[0], tc1[1], tc1[2], &c1[0], &c1[1], &c1[2]);
        }
      }
    }
    if (!c1.allFinite()) {
      // A c1 never computed (axial method with a closest point that failed): OpenSim goes on
      // with NaN. Fallback: the surface point closest to the segment's midpoint.
      status |= kWrapDegenerate;
      const V3 mid = 0.5 * (r1 + r2);
      c1 = mid.cwiseQuotient(a).normalized().cwiseProduct(a);
      if (!r1.allFinite()) r1 = r2 = c1;
    }
    // Wrapping plane through p1, p2 and c1.
    const V3 p1c1 = p1 - c1;
    V3 vs = p1p2.cross(p1c1);
    NormalizeOrZero(vs, vs);
    if (vs.isZero()) {
      // c1 on the line p1p2 (an end point on the surface): no plane, NaN in OpenSim. Fallback:
      // the plane through the segment and the centre, or any plane holding the segment.
      status |= kWrapDegenerate;
      vs = p1p2.cross(p1 - m);
      if (vs.norm() < 1e-12 * p1p2.norm() * (p1 - m).norm()) {
        Eigen::Index k = 0;
        p1p2.cwiseAbs().minCoeff(&k);
        vs = p1p2.cross(V3::Unit(k));
      }
      vs.normalize();
    }
    const double vs4 = -vs.dot(c1);
    CalcTangentPoint(p1e, r1, p1, m, a, vs, vs4);
    CalcTangentPoint(p2e, r2, p2, m, a, vs, vs4);
    bool far_side_wrap = false;
    V3 w1, w2;
    int num_pts = 0;
    double length =
        CalcDistanceOnEllipsoid(r1, r2, m, a, vs, vs4, far_side_wrap, factor, w1, w2, num_pts);
    if (wrap_sign != 0 && num_pts > 2 && !far_side_wrap) {
      V3 r1p1 = p1 - r1, r1w1 = w1 - r1, r2p2 = p2 - r2, r2w2 = w2 - r2;
      NormalizeOrZero(r1p1, r1p1);
      NormalizeOrZero(r1w1, r1w1);
      NormalizeOrZero(r2p2, r2p2);
      NormalizeOrZero(r2w2, r2w2);
      if (r1p1.dot(r1w1) > 0.0 || r2p2.dot(r2w2) > 0.0) {
        far_side_wrap = true;
        length =
            CalcDistanceOnEllipsoid(r1, r2, m, a, vs, vs4, far_side_wrap, factor, w1, w2, num_pts);
      }
    }
    w.length = length / factor;
    w.r1 = r1 / factor;
    w.r2 = r2 / factor;
    w.far_side = far_side_wrap;
    w.plane_normal = vs;
    w.has_path = num_pts > 0;
    w.code = 3;  // mandatoryWrap
    w.status |= status;
    return w;
  }
};

// ---- WrapTorus ------------------------------------------------------------------------------

struct CircleCallback {
  double p1[3], p2[3], r;
};

// WrapTorus::calcCircleResids (as written: its residual is not the derivative of the squared
// distance to the circle, whose last term has half this coefficient).
void CalcCircleResids(int, int, double q[], double resid[], int*, void* ptr) {
  const CircleCallback* cb = static_cast<const CircleCallback*>(ptr);
  const double u = q[0];
  const double mag = std::sqrt((cb->p2[0] - cb->p1[0]) * (cb->p2[0] - cb->p1[0]) +
                               (cb->p2[1] - cb->p1[1]) * (cb->p2[1] - cb->p1[1]) +
                               (cb->p2[2] - cb->p1[2]) * (cb->p2[2] - cb->p1[2]));
  const double nx = (cb->p2[0] - cb->p1[0]) / mag;
  const double ny = (cb->p2[1] - cb->p1[1]) / mag;
  const double nz = (cb->p2[2] - cb->p1[2]) / mag;
  const double c2 = 2.0 * (cb->p1[0] * nx + cb->p1[1] * ny + cb->p1[2] * nz);
  const double c3 = cb->p1[0] * nx + cb->p1[1] * ny;
  const double c4 = nx * nx + ny * ny;
  const double c5 = cb->p1[0] * cb->p1[0] + cb->p1[1] * cb->p1[1];
  resid[0] = c2 + 2.0 * u -
             2.0 * cb->r * (2.0 * c4 * u + 2.0 * c3) / std::sqrt(u * u * c4 + 2.0 * c3 * u + c5);
}

// WrapTorus::findClosestPoint: the point of the ring circle (radius `radius`, z = 0) nearest the
// line p1p2, from two lmdif passes; 0 when a constrained torus has neither on its side.
int TorusClosestPoint(double radius, const V3& p1, const V3& p2, V3& closest, int wrap_sign,
                      int wrap_axis, unsigned& status) {
  int info = 0, num_func_calls = 0;
  double q[2], resid[2], fjac[2];
  int ipvt[2];
  double diag[2], qtf[2], wa1[2], wa2[2], wa3[2], wa4[2];
  const bool constrained = wrap_sign != 0;
  const double ftol = 1e-4, xtol = 1e-4, gtol = 0.0, epsfcn = 0.0, step_factor = 0.2;
  const int mode = 1, nprint = 0, max_iter = 500;
  auto pass = [&](const V3& from, const V3& to, double& distance) {
    CircleCallback cb{{from[0], from[1], from[2]}, {to[0], to[1], to[2]}, radius};
    q[0] = 0.0;
    lmdif_port::lmdif_C(CalcCircleResids, 1, 1, q, resid, ftol, xtol, gtol, max_iter, epsfcn, diag,
                        mode, step_factor, nprint, &info, &num_func_calls, fjac, 1, ipvt, qtf, wa1,
                        wa2, wa3, wa4, &cb);
    if (info == 5) status |= kWrapNotConverged;
    const double u = q[0];
    const V3 n = (to - from) / (to - from).norm();
    const V3 x = from + u * n;
    distance = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + radius * radius -
                         2.0 * radius * std::sqrt(x[0] * x[0] + x[1] * x[1]));
    return x;
  };
  double distance1 = 0, distance2 = 0;
  const V3 a1 = pass(p1, p2, distance1);
  const V3 a2 = pass(p2, p1, distance2);
  int betterPt = 0;
  if (constrained) {
    if (Dsign(a1[wrap_axis]) == wrap_sign && Dsign(a2[wrap_axis]) == wrap_sign) {
      betterPt = distance1 < distance2 ? 0 : 1;
    } else if (Dsign(a1[wrap_axis]) == wrap_sign) {
      betterPt = 0;
    } else if (Dsign(a2[wrap_axis]) == wrap_sign) {
      betterPt = 1;
    } else {
      return 0;
    }
  } else {
    betterPt = distance1 < distance2 ? 0 : 1;
  }
  const V3& best = betterPt == 0 ? a1 : a2;
  const double mag = std::sqrt(best[0] * best[0] + best[1] * best[1]);
  closest = V3(best[0] * radius / mag, best[1] * radius / mag, 0.0);
  return 1;
}

}  // namespace

OsSegment OpenSimCylinder(double radius, double length, const WrapQuadrant& quadrant, const V3& p1,
                          const V3& p2, bool single_wrap) {
  const Cylinder c{radius, length, quadrant.axis, quadrant.sign};
  return c.WrapLine(p1, p2, single_wrap);
}

OsSegment OpenSimSphere(double radius, const WrapQuadrant& quadrant, const V3& p1, const V3& p2) {
  return SphereWrapLine(radius, quadrant.axis, quadrant.sign, p1, p2);
}

OsSegment OpenSimEllipsoid(const V3& radii, const WrapQuadrant& quadrant, WrapMethod method,
                           const V3& p1, const V3& p2) {
  const Ellipsoid e{radii, quadrant.axis, quadrant.sign};
  return e.WrapLine(method, p1, p2);
}

// WrapTorus::wrapLine: a cylinder of the tube radius, 10000 long, tangent to the ring circle at
// the point closest to the segment, constrained to "+x" (towards the ring's centre), wrapped by
// WrapCylinder::wrapLine in its own frame. The torus returns `wrapped` whatever the cylinder
// said; the tangent points count only when the cylinder wrapped (its wrap points).
OsSegment OpenSimTorus(double inner_radius, double outer_radius, const WrapQuadrant& quadrant,
                       const V3& p1, const V3& p2, bool single_wrap) {
  OsSegment w;
  w.flag = true;
  unsigned status = 0;
  V3 closestPt;
  if (TorusClosestPoint(outer_radius, p1, p2, closestPt, quadrant.sign, quadrant.axis, status) ==
      0) {
    w.code = 0;
    w.status = status;
    return w;
  }
  closestPt *= -1;
  V3 cylXaxis;
  NormalizeOrZero(closestPt, cylXaxis);
  const V3 cylYaxis(0.0, 0.0, -1.0);
  const V3 cylZaxis = cylXaxis.cross(cylYaxis);
  // SimTK::Rotation(Mat33(x0, x1, x2, y0, y1, y2, z0, z1, z2)): rows are the cylinder axes.
  Eigen::Matrix3d R;
  R.row(0) = cylXaxis.transpose();
  R.row(1) = cylYaxis.transpose();
  R.row(2) = cylZaxis.transpose();
  // cylinderToTorus = Transform(R, p) with p = R * closestPt; shiftFrameStationToBase(x) = R x + p.
  const V3 p = R * closestPt;
  const V3 q1 = R * p1 + p;
  const V3 q2 = R * p2 + p;
  const WrapQuadrant plus_x{0, 1};  // the default _wrapAxis 0, _wrapSign 1 of a fresh object
  OsSegment c = OpenSimCylinder(inner_radius, 10000.0, plus_x, q1, q2, single_wrap);
  if (c.flag && c.code > 0) {
    // shiftBaseStationToFrame(x) = R^T (x - p)
    c.r1 = R.transpose() * (c.r1 - p);
    c.r2 = R.transpose() * (c.r2 - p);
  }
  c.code = 2;  // the torus returns `wrapped`
  c.status |= status;
  c.plane_normal = R.row(2).transpose();  // the cylinder axis, in the torus frame
  return c;
}

}  // namespace isowrench::wrap_impl
