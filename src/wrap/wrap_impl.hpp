#pragma once
// Private: the wrap algorithms behind include/isowrench/wrap.hpp.
//  - opensim_wrap.cpp: OpenSim 4.x's WrapCylinder/WrapSphere/WrapEllipsoid/WrapTorus::wrapLine
//    and WrapMath, ported line by line (each function names what it follows);
//  - exact_wrap.cpp: the stationary (shortest) path over each surface on the side OpenSim's
//    rules choose (closed forms for the cylinder and the sphere, a geodesic Newton solve for the
//    ellipsoid and the torus);
//  - wrap_path.cpp: GeometryPath::applyWrapObjects and calcLengthAfterPathComputation;
//  - wrap_lmdif.cpp: OpenSim's MINPACK lmdif, which WrapTorus::findClosestPoint calls.

#include <Eigen/Core>

#include "isowrench/wrap.hpp"

namespace isowrench::wrap_impl {

using V3 = Eigen::Vector3d;

/// One segment's OpenSim answer in the wrap object's frame S (WrapResult + wrapLine's return
/// code and aFlag). `has_path`: the WrapResult holds wrap points (wrap_pts non-empty), the
/// condition under which GeometryPath::applyWrapObjects inserts the tangent points.
struct OsSegment {
  int code = 0;  // WrapObject::WrapAction: 0 noWrap, 1 insideRadius, 2 wrapped, 3 mandatoryWrap
  bool flag = false;      // wrapLine's aFlag
  bool has_path = false;  // wrap_pts non-empty
  V3 r1 = V3::Zero(), r2 = V3::Zero();
  double length = 0.0;  // wrap_path_length
  unsigned status = 0;  // WrapStatus bits
  /// Cylinder (and the torus's cylinder): the path went the long way around (long_wrap).
  bool far_side = false;
  /// Sphere: the unit normal of the plane of the arc (r1 x r2 direction of travel), for the
  /// exact mode's choice of side; cylinder: the sense of rotation about the axis (+1/-1).
  V3 plane_normal = V3::Zero();
  int sense = 0;
};

OsSegment OpenSimCylinder(double radius, double length, const WrapQuadrant& quadrant, const V3& p1,
                          const V3& p2, bool single_wrap);
// OpenSimCylinderSingle (the cylinder of a muscle with one wrap, for the engine): in
// wrap/cylinder_single.hpp.
OsSegment OpenSimSphere(double radius, const WrapQuadrant& quadrant, const V3& p1, const V3& p2);
OsSegment OpenSimEllipsoid(const V3& radii, const WrapQuadrant& quadrant, WrapMethod method,
                           const V3& p1, const V3& p2);
OsSegment OpenSimTorus(double inner_radius, double outer_radius, const WrapQuadrant& quadrant,
                       const V3& p1, const V3& p2, bool single_wrap);

/// The exact stationary path for the same segment, starting from OpenSim's answer `os` (whose
/// code and tangent-point side it keeps). Fills r1, r2, length; may add status bits.
OsSegment ExactSegment(const WrapSurface& surface, const V3& p1, const V3& p2, const OsSegment& os);

/// OpenSim's answer `os` for the segment p1 -> p2 over `s` as ComputeWrappedPath uses it: no
/// wrap (kWrapDegenerate) when it reached a NaN, and in kExact the exact path (ExactSegment).
OsSegment SegmentInMode(OsSegment os, const WrapSurface& s, const V3& p1, const V3& p2,
                        WrapMode mode);

namespace lmdif_port {
/// OpenSim's lmdif_C (OpenSim/Common/Lmdif.cpp), see wrap_lmdif.cpp.
void lmdif_C(void (*fcn)(int, int, double[], double[], int*, void*), int m, int n, double x[],
             double fvec[], double ftol, double xtol, double gtol, int maxfev, double epsfcn,
             double diag[], int mode, double factor, int nprint, int* info, int* nfev,
             double fjac[], int ldfjac, int ipvt[], double qtf[], double wa1[], double wa2[],
             double wa3[], double wa4[], void* data);
}  // namespace lmdif_port

}  // namespace isowrench::wrap_impl
