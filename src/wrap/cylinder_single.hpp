#pragma once
// Private: OpenSim's WrapCylinder::wrapLine for a muscle with one wrap, inline so that the
// engine's one-cylinder evaluation (src/fast/one_cylinder.hpp) compiles it into its kernel.

#include <cmath>
#include <limits>

#include "wrap/wrap_impl.hpp"

namespace isowrench::wrap_impl {
namespace cylinder_single {
// The constants and helpers of opensim_wrap.cpp that it uses (the same values).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kPi = 3.14159265358979323846;                        // SimTK_PI
inline constexpr double kSimTKEps = std::numeric_limits<double>::epsilon();  // SimTK::Eps
inline constexpr double kRoundoffError = 0.0000000000002;  // SimmMacros.h ROUNDOFF_ERROR
inline constexpr double kLineEpsilon = 0.00001;            // WrapMath.cpp LINE_EPSILON
inline int Dsign(double a) { return a >= 0.0 ? 1 : -1; }   // SimmMacros.h

/// std::atan2(y, x) in about a third of libm's instructions, within 4.5e-16 rad of it (tested
/// in tests/wrap/wrap_test.cpp), with its signs of zero and its quadrants: atan(t) of
/// t = min(|x|, |y|) / max(|x|, |y|) as atan(c) + atan(v), c = k / 8 the nearest eighth
/// (atan(c) tabulated: std::atan(k / 8.0) printed to 17 digits) and v = (t - c) / (1 + t c),
/// |v| <= 1/16, by its Taylor series to v^13 (the next term is below 1e-18 of v). A NaN and
/// inf / inf go to std::atan2.
inline double Atan2(double y, double x) {
  static constexpr double kAtanEighths[9] = {0.0,
                                             0.12435499454676144,
                                             0.24497866312686414,
                                             0.35877067027057225,
                                             0.46364760900080609,
                                             0.55859931534356244,
                                             0.64350110879328437,
                                             0.71882999962162453,
                                             0.78539816339744828};
  constexpr double kHalfPi = 1.57079632679489661923;
  const double ax = std::fabs(x), ay = std::fabs(y);
  const bool steep = ay > ax;
  const double num = steep ? ax : ay, den = steep ? ay : ax;
  double a = 0.0;
  if (den > 0.0) {
    const double t = num / den;
    if (!(t <= 1.0)) return std::atan2(y, x);  // a NaN, or inf / inf
    const int k = static_cast<int>(t * 8.0 + 0.5);
    const double c = k * 0.125;
    const double v = (t - c) / (1.0 + t * c);
    const double z = v * v;
    const double p =
        -1.0 / 3.0 +
        z * (1.0 / 5.0 + z * (-1.0 / 7.0 + z * (1.0 / 9.0 + z * (-1.0 / 11.0 + z * (1.0 / 13.0)))));
    a = kAtanEighths[k] + (v + v * z * p);
  } else if (std::isnan(x) || std::isnan(y)) {
    return x + y;
  }
  if (steep) a = kHalfPi - a;
  if (std::signbit(x)) a = kPi - a;
  return std::signbit(y) ? -a : a;
}
}  // namespace cylinder_single

// WrapCylinder::wrapLine for a muscle with one wrap (single_wrap: _make_spiral_path adjusts no
// tangent point), opensim_wrap.cpp's Cylinder::WrapLine with its constants written out: the axis is
// z (p0 = (0, 0, -1), dn = (0, 0, 1)), so a closest point on the axis is (0, 0, z), a distance to
// it is the one in the x-y plane, the tangent points and the apex are found in the cross-section,
// and the two acos of the constrained side's choice are compared as their cosines (acos
// decreases). Every test, branch and degenerate case of WrapLine is kept in the same order; the
// numbers are WrapLine's to rounding (the port reaches (0, 0, z) as -1 + (z + 1), and the plane
// intersection as z - 10 + 20 t). The engine's one-cylinder path stage compiles it in
// (src/fast/one_cylinder.hpp); tests/wrap/wrap_test.cpp compares it with WrapLine.
inline __attribute__((always_inline)) OsSegment OpenSimCylinderSingle(double radius, double length,
                                                                      const WrapQuadrant& quadrant,
                                                                      const V3& aPoint1,
                                                                      const V3& aPoint2) {
  using namespace cylinder_single;
  OsSegment w;
  w.r1 = V3::Constant(kNaN);
  w.r2 = V3::Constant(kNaN);
  const double R = radius;
  const double r_squared = R * R;
  const int axis = quadrant.axis;
  const int sign = quadrant.sign;
  const bool constrained = sign != 0;
  const double x1 = aPoint1.x(), y1 = aPoint1.y(), z1 = aPoint1.z();
  const double x2 = aPoint2.x(), y2 = aPoint2.y(), z2 = aPoint2.z();
  const double d1_squared = x1 * x1 + y1 * y1;  // DistanceSquaredPointToLine(aPoint1, p0, dn)
  const double d2_squared = x2 * x2 + y2 * y2;
  if (d1_squared < r_squared || d2_squared < r_squared) {
    w.code = 1;
    return w;
  }
  int return_code = 2;
  // IntersectLines(aPoint1, aPoint2, cylStart, cylEnd): the point near12 of the segment's line
  // closest to the axis, its parameter t12 (0 at aPoint1, 1 at aPoint2) and its squared distance
  // to the axis; near12 = 0 and t12 = NaN when the line is parallel to the axis.
  const V3 d = aPoint2 - aPoint1;
  const double dxy_squared = d.x() * d.x() + d.y() * d.y();
  const double d_squared = dxy_squared + d.z() * d.z();
  double t12 = kNaN, near_squared = 0.0;
  V3 near12 = V3::Zero();
  if (std::sqrt(d_squared) >= kSimTKEps && length >= kSimTKEps &&
      !(dxy_squared <= kRoundoffError * d_squared)) {
    t12 = -(x1 * d.x() + y1 * d.y()) / dxy_squared;
    near12 = aPoint1 + t12 * d;
    near_squared = near12.x() * near12.x() + near12.y() * near12.y();
  }
  const bool crosses = near_squared < r_squared && t12 > 0.0 && t12 < 1.0;
  if (!constrained) {
    if (!crosses) {
      w.code = 0;
      return w;
    }
    return_code = 3;
  }
  // The two tangent points from each end point (in the cross-section at the point's z).
  const double p11_dist = std::sqrt(d1_squared);
  const double p22_dist = std::sqrt(d2_squared);
  auto tangents = [&](double x, double y, double z, double dist, V3& a, V3& b) {
    double ex = 0.0, ey = 0.0;  // NormalizeOrZero
    if (dist >= kSimTKEps) {
      ex = x * (1.0 / dist);
      ey = y * (1.0 / dist);
    }
    const double sin_theta = R / dist;
    const double along = R * sin_theta;
    const double across = std::sqrt(r_squared - along * along);
    const double px = along * ex, py = along * ey;
    a = V3(px - across * ey, py + across * ex, z);
    b = V3(px + across * ey, py - across * ex, z);
  };
  V3 r1a, r1b, r2a, r2b;
  tangents(x1, y1, z1, p11_dist, r1a, r1b);
  tangents(x2, y2, z2, p22_dist, r2a, r2b);
  bool far_side_wrap = false, long_wrap = false;
  if (constrained) {
    if (Dsign(aPoint1[axis]) == sign || Dsign(aPoint2[axis]) == sign) {
      if (crosses) {
        return_code = 3;
      } else if (Dsign(aPoint1[axis]) != Dsign(aPoint2[axis]) && Dsign(near12[axis]) != sign) {
        return_code = 2;
      } else {
        w.code = 0;
        return w;
      }
    }
    // alpha > beta (the angles r1a-r2b and r1b-r2a about the axis) as cos alpha < cos beta; a
    // NaN acos (a cosine outside [-1, 1]) compares false.
    auto cosine = [](const V3& a, const V3& b) {
      return (a.x() * b.x() + a.y() * b.y()) /
             (std::sqrt(a.x() * a.x() + a.y() * a.y()) * std::sqrt(b.x() * b.x() + b.y() * b.y()));
    };
    const double cos_alpha = cosine(r1a, r2b), cos_beta = cosine(r1b, r2a);
    const bool alpha_gt_beta = cos_alpha >= -1.0 && cos_alpha <= 1.0 && cos_beta >= -1.0 &&
                               cos_beta <= 1.0 && cos_alpha < cos_beta;
    if (Dsign(r1a[axis]) == sign && Dsign(r1b[axis]) == sign) {
      if (Dsign(r2a[axis]) == sign) {
        w.r1 = r1b;
        w.r2 = r2a;
        far_side_wrap = !alpha_gt_beta;
      } else {
        w.r1 = r1a;
        w.r2 = r2b;
        far_side_wrap = alpha_gt_beta;
      }
    } else if (Dsign(r1a[axis]) == sign && Dsign(r1b[axis]) != sign) {
      w.r1 = r1a;
      w.r2 = r2b;
      far_side_wrap = alpha_gt_beta;
    } else if (Dsign(r1a[axis]) != sign && Dsign(r1b[axis]) == sign) {
      w.r1 = r1b;
      w.r2 = r2a;
      far_side_wrap = !alpha_gt_beta;
    } else {
      if (Dsign(r2a[axis]) == sign) {
        w.r1 = r1b;
        w.r2 = r2a;
        far_side_wrap = !alpha_gt_beta;
      } else if (Dsign(r2b[axis]) == sign) {
        w.r1 = r1a;
        w.r2 = r2b;
        far_side_wrap = alpha_gt_beta;
      } else {
        if (alpha_gt_beta) {
          w.r1 = r1a;
          w.r2 = r2b;
        } else {
          w.r1 = r1b;
          w.r2 = r2a;
        }
        far_side_wrap = true;
      }
    }
    // sum_r . sum_musc < 0 (their z components are rounding: the tangent points lie in the
    // cross-sections of their end points)
    const double mx = (w.r1.x() - x1) + (w.r2.x() - x2), my = (w.r1.y() - y1) + (w.r2.y() - y2);
    const double rx = w.r1.x() + w.r2.x(), ry = w.r1.y() + w.r2.y();
    if (rx * mx + ry * my < 0.0) long_wrap = true;
  } else {
    auto unit2 = [](const V3& a, double& ux, double& uy) {  // NormalizeOrZero in the plane
      const double mag = std::sqrt(a.x() * a.x() + a.y() * a.y());
      ux = uy = 0.0;
      if (mag >= kSimTKEps) {
        ux = a.x() * (1.0 / mag);
        uy = a.y() * (1.0 / mag);
      }
    };
    double ax1, ay1, bx1, by1, ax2, ay2, bx2, by2;
    unit2(r1a, ax1, ay1);
    unit2(r1b, bx1, by1);
    unit2(r2a, ax2, ay2);
    unit2(r2b, bx2, by2);
    const double dot1 = ax1 * ax2 + ay1 * ay2, dot2 = ax1 * bx2 + ay1 * by2,
                 dot3 = bx1 * ax2 + by1 * ay2, dot4 = bx1 * bx2 + by1 * by2;
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
  // The apex: the point of the cylinder's edge on the bisecting plane (WrapLine's plane_normal
  // through the axis point at the muscle's division point; vert2 = -vert1).
  const double t = p11_dist / (p11_dist + p22_dist);
  const V3 mpt = aPoint1 + t * d;
  const V3 l1(x1, y1, z1 - mpt.z()), l2(x2, y2, z2 - mpt.z());
  const V3 normal = l1.cross(l2);  // (its length does not matter: only vert1's direction)
  double vx = -normal.y(), vy = normal.x();
  const double v_norm = std::sqrt(vx * vx + vy * vy);
  const double n_norm = normal.norm();
  if (n_norm > 0.0 && v_norm >= kSimTKEps * n_norm) {  // (NaN: vert1 = 0)
    vx /= v_norm;
    vy /= v_norm;
  } else {
    vx = vy = 0.0;
  }
  // dist1 < dist2 (apex1 = axispt + R vert1 nearer mpt than apex2 = axispt - R vert1)
  const bool near1 = mpt.x() * vx + mpt.y() * vy > 0.0;
  const double apex_sign = (near1 != far_side_wrap) ? 1.0 : -1.0;
  const V3 apex(apex_sign * R * vx, apex_sign * R * vy, mpt.z());
  // Slide r1/r2 along the axis onto the plane through aPoint1, aPoint2 and the apex
  // (IntersectLineSegPlane over +-10 along the axis, kept where it lies between p11 and p22).
  // (WrapLine normalizes aPoint - apex first: the unit normal of their cross product is the
  // same, and a zero vector gives the same NaN normal)
  const V3 cross = (aPoint1 - apex).cross(aPoint2 - apex);
  const V3 plane_normal = cross / cross.norm();  // (SimTK::UnitVec3: NaN for 0)
  const double plane_d = -aPoint1.dot(plane_normal);
  const double dotprod = 20.0 * plane_normal.z();
  const double inverse_nz = 1.0 / plane_normal.z();
  auto slide = [&](V3& r, double z_far) {
    if (std::fabs(dotprod) < kLineEpsilon) return;
    const double z_shift = (-plane_d - plane_normal.x() * r.x() - plane_normal.y() * r.y() -
                            plane_normal.z() * r.z()) *
                           inverse_nz;
    const double tt = (z_shift + 10.0) / 20.0;
    if (tt < -kLineEpsilon || tt > 1.0 + kLineEpsilon) return;
    // (IntersectLineSegPlane's NaN t passes its range test, and the distance test below fails)
    const double z = r.z() + z_shift;
    if ((z - z_far) * (z - z_far) < (z1 - z2) * (z1 - z2)) r.z() = z;
  };
  slide(w.r1, z2);  // kept when nearer p22 than p11 is (along the axis)
  slide(w.r2, z1);  // and r2 when nearer p11 than p22 is
  const double halfL = length / 2.0;
  if ((w.r1[2] < -halfL || w.r1[2] > halfL) && (w.r2[2] < -halfL || w.r2[2] > halfL)) {
    w.code = 0;
    return w;
  }
  // _make_spiral_path without the adjustment.
  const double axial_dist = w.r2.z() - w.r1.z();
  double theta =
      Atan2(w.r1.x() * w.r2.y() - w.r1.y() * w.r2.x(), w.r1.x() * w.r2.x() + w.r1.y() * w.r2.y());
  if (long_wrap) theta = 2.0 * kPi - theta;
  const double x = R * theta;
  w.length = std::sqrt(x * x + axial_dist * axial_dist);
  w.sense = ((long_wrap ? -1.0 : 1.0) * theta >= 0.0) ? 1 : -1;
  w.has_path = true;
  w.far_side = long_wrap;
  w.flag = true;
  w.code = return_code;
  return w;
}

}  // namespace isowrench::wrap_impl
