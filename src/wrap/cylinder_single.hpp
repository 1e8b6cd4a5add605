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
/// t = min(|x|, |y|) / max(|x|, |y|) as atan(c) + atan(v), c = k / 32 the nearest 32nd
/// (atan(c) tabulated: std::atan(k / 32.0) printed to 17 digits) and v = (t - c) / (1 + t c),
/// |v| <= 1/64, by its Taylor series to v^7 (the next term is below 7e-18 rad). A NaN and
/// inf / inf go to std::atan2.
inline double Atan2(double y, double x) {
  // atan(k / 32), k = 0..32
  static constexpr double kAtan32nds[33] = {0.0,
                                            0.031239833430268277,
                                            0.06241880999595735,
                                            0.09347678115858947,
                                            0.12435499454676144,
                                            0.15499674192394097,
                                            0.18534794999569476,
                                            0.21535769969773805,
                                            0.24497866312686414,
                                            0.27416745111965879,
                                            0.30288486837497142,
                                            0.3310960767041321,
                                            0.35877067027057225,
                                            0.38588266939807375,
                                            0.41241044159738732,
                                            0.43833655985795783,
                                            0.46364760900080609,
                                            0.48833395105640554,
                                            0.51238946031073773,
                                            0.5358112379604637,
                                            0.55859931534356244,
                                            0.58075635356767041,
                                            0.60228734613496415,
                                            0.6231993299340659,
                                            0.64350110879328437,
                                            0.66320299270609329,
                                            0.68231655487474807,
                                            0.70085440788445019,
                                            0.71882999962162453,
                                            0.7362574289814281,
                                            0.75315128096219441,
                                            0.7695264804056583,
                                            0.78539816339744828};
  constexpr double kHalfPi = 1.57079632679489661923;
  const double ax = std::fabs(x), ay = std::fabs(y);
  const bool steep = ay > ax;
  const double num = steep ? ax : ay, den = steep ? ay : ax;
  double a = 0.0;
  if (den > 0.0) {
    const double t = num / den;
    if (!(t <= 1.0)) return std::atan2(y, x);  // a NaN, or inf / inf
    const int k = static_cast<int>(t * 32.0 + 0.5);
    const double c = k * 0.03125;
    const double v = (t - c) / (1.0 + t * c);
    const double z = v * v;
    const double p = -1.0 / 3.0 + z * (1.0 / 5.0 + z * (-1.0 / 7.0));
    a = kAtan32nds[k] + (v + v * z * p);
  } else if (std::isnan(x) || std::isnan(y)) {
    return x + y;
  }
  if (steep) a = kHalfPi - a;
  if (std::signbit(x)) a = kPi - a;
  return std::signbit(y) ? -a : a;
}
}  // namespace cylinder_single

/// OpenSimCylinderSingle's result without Eigen (what the engine reads): scalars that the
/// engine's kernel keeps in registers. r1, r2 and length are set only when `wraps` (has_path
/// and flag; code 2 or 3), 0 otherwise.
struct CylinderSingleResult {
  int code = 0;  // WrapObject::WrapAction: 0 noWrap, 1 insideRadius, 2 wrapped, 3 mandatoryWrap
  bool wraps = false;     // has_path and flag
  bool far_side = false;  // long_wrap
  int sense = 0;          // +1/-1: the sense of rotation about the axis
  double r1x = 0.0, r1y = 0.0, r1z = 0.0, r2x = 0.0, r2y = 0.0, r2z = 0.0;
  double length = 0.0;  // wrap_path_length
};

// WrapCylinder::wrapLine for a muscle with one wrap (single_wrap: _make_spiral_path adjusts no
// tangent point), opensim_wrap.cpp's Cylinder::WrapLine with its constants written out: the axis is
// z (p0 = (0, 0, -1), dn = (0, 0, 1)), so a closest point on the axis is (0, 0, z), a distance to
// it is the one in the x-y plane, the tangent points and the apex are found in the cross-section,
// and the two acos of the constrained side's choice are compared as their cosines (acos
// decreases). Every test, branch and degenerate case of WrapLine is kept in the same order; the
// numbers are WrapLine's to rounding (the port reaches (0, 0, z) as -1 + (z + 1), and the plane
// intersection as z - 10 + 20 t). Written over scalars (no Eigen vector, no component picked by
// a run-time index through memory), so that the engine's one-cylinder path stage
// (src/fast/one_cylinder.hpp), which compiles it in, keeps it in registers; the end points
// (x1, y1, z1) and (x2, y2, z2) are in the cylinder's frame, `axis` and `sign` its quadrant
// (WrapQuadrant). tests/wrap/wrap_test.cpp compares it (through OpenSimCylinderSingle) with
// WrapLine.
inline __attribute__((always_inline)) CylinderSingleResult CylinderSingle(double R, double length,
                                                                          int axis, int sign,
                                                                          double x1, double y1,
                                                                          double z1, double x2,
                                                                          double y2, double z2) {
  using namespace cylinder_single;
  CylinderSingleResult w;
  const double r_squared = R * R;
  const bool constrained = sign != 0;
  // Dsign(v[axis]) == sign for v = (x, y, z): the quadrant's side. v[axis] is picked as
  // x c_x + y c_y + z c_z with c = the unit vector of the axis (exactly v[axis] for a finite v,
  // up to the sign of a zero, which Dsign does not tell apart), without a branch or a store.
  const double c_x = axis == 0 ? 1.0 : 0.0, c_y = axis == 1 ? 1.0 : 0.0,
               c_z = axis == 2 ? 1.0 : 0.0;
  auto on_side = [=](double x, double y, double z) {
    return Dsign(x * c_x + y * c_y + z * c_z) == sign;
  };
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
  const double dx = x2 - x1, dy = y2 - y1, dz = z2 - z1;
  const double dxy_squared = dx * dx + dy * dy;
  const double d_squared = dxy_squared + dz * dz;
  double t12 = kNaN, near_squared = 0.0;
  double near_x = 0.0, near_y = 0.0, near_z = 0.0;
  if (std::sqrt(d_squared) >= kSimTKEps && length >= kSimTKEps &&
      !(dxy_squared <= kRoundoffError * d_squared)) {
    t12 = -(x1 * dx + y1 * dy) / dxy_squared;
    near_x = x1 + t12 * dx;
    near_y = y1 + t12 * dy;
    near_z = z1 + t12 * dz;
    near_squared = near_x * near_x + near_y * near_y;
  }
  const bool crosses = near_squared < r_squared && t12 > 0.0 && t12 < 1.0;
  if (!constrained) {
    if (!crosses) {
      w.code = 0;
      return w;
    }
    return_code = 3;
  }
  // The two tangent points a, b from each end point (in the cross-section at the point's z,
  // which is theirs).
  const double p11_dist = std::sqrt(d1_squared);
  const double p22_dist = std::sqrt(d2_squared);
  auto tangents = [&](double x, double y, double dist, double& ax, double& ay, double& bx,
                      double& by) {
    double ex = 0.0, ey = 0.0;  // NormalizeOrZero
    if (dist >= kSimTKEps) {
      ex = x * (1.0 / dist);
      ey = y * (1.0 / dist);
    }
    const double sin_theta = R / dist;
    const double along = R * sin_theta;
    const double across = std::sqrt(r_squared - along * along);
    const double px = along * ex, py = along * ey;
    ax = px - across * ey;
    ay = py + across * ex;
    bx = px + across * ey;
    by = py - across * ex;
  };
  double r1ax, r1ay, r1bx, r1by, r2ax, r2ay, r2bx, r2by;
  tangents(x1, y1, p11_dist, r1ax, r1ay, r1bx, r1by);
  tangents(x2, y2, p22_dist, r2ax, r2ay, r2bx, r2by);
  bool far_side_wrap = false, long_wrap = false;
  double r1x, r1y, r2x, r2y;  // the chosen tangent points (r1 at z1, r2 at z2)
  if (constrained) {
    const bool side1 = on_side(x1, y1, z1), side2 = on_side(x2, y2, z2);
    if (side1 || side2) {
      if (crosses) {
        return_code = 3;
      } else if (side1 != side2 && !on_side(near_x, near_y, near_z)) {
        // (Dsign(aPoint1[axis]) != Dsign(aPoint2[axis]): one of them is on the side)
        return_code = 2;
      } else {
        w.code = 0;
        return w;
      }
    }
    // alpha > beta (the angles r1a-r2b and r1b-r2a about the axis) as cos alpha < cos beta; a
    // NaN acos (a cosine outside [-1, 1]) compares false. Every tangent point lies at R from the
    // axis (to a few ulp), so the cosines are the dot products over R^2 to ~1e-15: the dot
    // products decide alone when they differ by more than 1e-12 R^2 and both lie within
    // (1 - 1e-12) R^2 of 0 (a NaN fails the tests); otherwise (a near tie, an angle near 0 or pi,
    // a degenerate tangent point) the normalised cosines decide, as WrapLine's acos do.
    const double dot_alpha = r1ax * r2bx + r1ay * r2by, dot_beta = r1bx * r2ax + r1by * r2ay;
    const double margin = 1e-12 * r_squared, inside = r_squared - margin;
    bool alpha_gt_beta;
    if (std::fabs(dot_alpha - dot_beta) > margin && std::fabs(dot_alpha) < inside &&
        std::fabs(dot_beta) < inside) {
      alpha_gt_beta = dot_alpha < dot_beta;
    } else {
      auto cosine = [](double dot, double ax, double ay, double bx, double by) {
        return dot / (std::sqrt(ax * ax + ay * ay) * std::sqrt(bx * bx + by * by));
      };
      const double cos_alpha = cosine(dot_alpha, r1ax, r1ay, r2bx, r2by);
      const double cos_beta = cosine(dot_beta, r1bx, r1by, r2ax, r2ay);
      alpha_gt_beta = cos_alpha >= -1.0 && cos_alpha <= 1.0 && cos_beta >= -1.0 &&
                      cos_beta <= 1.0 && cos_alpha < cos_beta;
    }
    // WrapLine's cases: r1 = r1a, r2 = r2b (far side when alpha > beta) or r1 = r1b, r2 = r2a
    // (far side when alpha <= beta); neither end's pair on the side: the larger angle, the far
    // side.
    const bool s1a = on_side(r1ax, r1ay, z1), s1b = on_side(r1bx, r1by, z1);
    bool choose_a;
    if (s1a && s1b) {
      choose_a = !on_side(r2ax, r2ay, z2);
    } else if (s1a) {
      choose_a = true;
    } else if (s1b) {
      choose_a = false;
    } else if (on_side(r2ax, r2ay, z2)) {
      choose_a = false;
    } else if (on_side(r2bx, r2by, z2)) {
      choose_a = true;
    } else {
      choose_a = alpha_gt_beta;
      far_side_wrap = true;
    }
    if (!far_side_wrap) far_side_wrap = choose_a == alpha_gt_beta;
    r1x = choose_a ? r1ax : r1bx;
    r1y = choose_a ? r1ay : r1by;
    r2x = choose_a ? r2bx : r2ax;
    r2y = choose_a ? r2by : r2ay;
    // sum_r . sum_musc < 0 (their z components are rounding: the tangent points lie in the
    // cross-sections of their end points)
    const double mx = (r1x - x1) + (r2x - x2), my = (r1y - y1) + (r2y - y2);
    const double rx = r1x + r2x, ry = r1y + r2y;
    if (rx * mx + ry * my < 0.0) long_wrap = true;
  } else {
    auto unit2 = [](double x, double y, double& ux, double& uy) {  // NormalizeOrZero in the plane
      const double mag = std::sqrt(x * x + y * y);
      ux = uy = 0.0;
      if (mag >= kSimTKEps) {
        ux = x * (1.0 / mag);
        uy = y * (1.0 / mag);
      }
    };
    double ax1, ay1, bx1, by1, ax2, ay2, bx2, by2;
    unit2(r1ax, r1ay, ax1, ay1);
    unit2(r1bx, r1by, bx1, by1);
    unit2(r2ax, r2ay, ax2, ay2);
    unit2(r2bx, r2by, bx2, by2);
    const double dot1 = ax1 * ax2 + ay1 * ay2, dot2 = ax1 * bx2 + ay1 * by2,
                 dot3 = bx1 * ax2 + by1 * ay2, dot4 = bx1 * bx2 + by1 * by2;
    bool first_a, second_a;
    if (dot1 > dot2 && dot1 > dot3 && dot1 > dot4) {
      first_a = second_a = true;
    } else if (dot2 > dot3 && dot2 > dot4) {
      first_a = true;
      second_a = false;
    } else if (dot3 > dot4) {
      first_a = false;
      second_a = true;
    } else {
      first_a = second_a = false;
    }
    r1x = first_a ? r1ax : r1bx;
    r1y = first_a ? r1ay : r1by;
    r2x = second_a ? r2ax : r2bx;
    r2y = second_a ? r2ay : r2by;
  }
  double r1z = z1, r2z = z2;
  // The apex: the point of the cylinder's edge on the bisecting plane (WrapLine's plane_normal
  // through the axis point at the muscle's division point; vert2 = -vert1).
  const double t = p11_dist / (p11_dist + p22_dist);
  const double mpt_x = x1 + t * dx, mpt_y = y1 + t * dy, mpt_z = z1 + t * dz;
  const double l1z = z1 - mpt_z, l2z = z2 - mpt_z;  // l1 = (x1, y1, l1z), l2 = (x2, y2, l2z)
  // normal = l1 x l2 (its length does not matter: only vert1's direction)
  const double normal_x = y1 * l2z - l1z * y2, normal_y = l1z * x2 - x1 * l2z,
               normal_z = x1 * y2 - y1 * x2;
  double vx = -normal_y, vy = normal_x;
  const double v_norm = std::sqrt(vx * vx + vy * vy);
  const double n_norm = std::sqrt(normal_x * normal_x + normal_y * normal_y + normal_z * normal_z);
  if (n_norm > 0.0 && v_norm >= kSimTKEps * n_norm) {  // (NaN: vert1 = 0)
    vx /= v_norm;
    vy /= v_norm;
  } else {
    vx = vy = 0.0;
  }
  // dist1 < dist2 (apex1 = axispt + R vert1 nearer mpt than apex2 = axispt - R vert1)
  const bool near1 = mpt_x * vx + mpt_y * vy > 0.0;
  const double apex_sign = (near1 != far_side_wrap) ? 1.0 : -1.0;
  const double apex_x = apex_sign * R * vx, apex_y = apex_sign * R * vy;
  // Slide r1/r2 along the axis onto the plane through aPoint1, aPoint2 and the apex
  // (IntersectLineSegPlane over +-10 along the axis, kept where it lies between p11 and p22).
  // (WrapLine normalizes aPoint - apex first: the unit normal of their cross product is the
  // same, and a zero vector gives the same NaN normal)
  const double u1x = x1 - apex_x, u1y = y1 - apex_y, u1z = z1 - mpt_z;
  const double u2x = x2 - apex_x, u2y = y2 - apex_y, u2z = z2 - mpt_z;
  const double cross_x = u1y * u2z - u1z * u2y, cross_y = u1z * u2x - u1x * u2z,
               cross_z = u1x * u2y - u1y * u2x;
  // The plane's unit normal n = cross / |cross| (SimTK::UnitVec3: NaN for 0) enters only as
  // n_z against LINE_EPSILON / 20 (IntersectLineSegPlane's parallel test, here on the squares)
  // and as the ratio (n . (aPoint1 - r)) / n_z, which is cross's own.
  const double cross_squared = cross_x * cross_x + cross_y * cross_y + cross_z * cross_z;
  constexpr double kParallel = (kLineEpsilon / 20.0) * (kLineEpsilon / 20.0);
  if (!(cross_z * cross_z < kParallel * cross_squared)) {  // (NaN: it slides to NaN: kept)
    const double inverse_z = 1.0 / cross_z;
    const double reach = (z1 - z2) * (z1 - z2);
    auto slide = [&](double rx, double ry, double& rz, double z_far) {
      const double z_shift =
          (cross_x * (x1 - rx) + cross_y * (y1 - ry) + cross_z * (z1 - rz)) * inverse_z;
      const double tt = (z_shift + 10.0) / 20.0;
      if (tt < -kLineEpsilon || tt > 1.0 + kLineEpsilon) return;
      // (IntersectLineSegPlane's NaN t passes its range test, and the distance test below
      // fails)
      const double z = rz + z_shift;
      if ((z - z_far) * (z - z_far) < reach) rz = z;
    };
    slide(r1x, r1y, r1z, z2);  // kept when nearer p22 than p11 is (along the axis)
    slide(r2x, r2y, r2z, z1);  // and r2 when nearer p11 than p22 is
  }
  const double halfL = length / 2.0;
  if ((r1z < -halfL || r1z > halfL) && (r2z < -halfL || r2z > halfL)) {
    w.code = 0;
    return w;
  }
  // _make_spiral_path without the adjustment.
  const double axial_dist = r2z - r1z;
  double theta = Atan2(r1x * r2y - r1y * r2x, r1x * r2x + r1y * r2y);
  if (long_wrap) theta = 2.0 * kPi - theta;
  const double x = R * theta;
  w.length = std::sqrt(x * x + axial_dist * axial_dist);
  w.sense = (long_wrap ? theta <= 0.0 : theta >= 0.0) ? 1 : -1;  // (-1 or 1) * theta >= 0
  w.r1x = r1x;
  w.r1y = r1y;
  w.r1z = r1z;
  w.r2x = r2x;
  w.r2y = r2y;
  w.r2z = r2z;
  w.wraps = true;
  w.far_side = long_wrap;
  w.code = return_code;
  return w;
}

/// CylinderSingle's result as an OsSegment (r1 and r2 NaN when it does not wrap, as WrapLine's).
inline OsSegment ToOsSegment(const CylinderSingleResult& c) {
  OsSegment w;
  w.code = c.code;
  w.r1 = V3::Constant(cylinder_single::kNaN);
  w.r2 = V3::Constant(cylinder_single::kNaN);
  if (c.wraps) {
    w.r1 = V3(c.r1x, c.r1y, c.r1z);
    w.r2 = V3(c.r2x, c.r2y, c.r2z);
    w.length = c.length;
    w.sense = c.sense;
    w.has_path = true;
    w.far_side = c.far_side;
    w.flag = true;
  }
  return w;
}

/// CylinderSingle for the cylinder's quadrant and end points as WrapLine takes them.
inline OsSegment OpenSimCylinderSingle(double radius, double length, const WrapQuadrant& quadrant,
                                       const V3& aPoint1, const V3& aPoint2) {
  return ToOsSegment(CylinderSingle(radius, length, quadrant.axis, quadrant.sign, aPoint1.x(),
                                    aPoint1.y(), aPoint1.z(), aPoint2.x(), aPoint2.y(),
                                    aPoint2.z()));
}

}  // namespace isowrench::wrap_impl
