#pragma once
/// @file
/// Muscle paths that wrap over OpenSim wrap objects (cylinder, sphere, ellipsoid, torus): one
/// segment over one surface (WrapSegment), and a muscle's whole path with its list of wraps at
/// one posture (ComputeWrappedPath, OpenSim's GeometryPath::applyWrapObjects). Every rule, with
/// the opensim-core file and function it follows, is in docs/opensim.md "Wrapping".
///
/// Two modes (WrapMode):
///  - kOpenSim: OpenSim 4.x's algorithms as written (WrapCylinder::wrapLine, ...), so lengths
///    are the ones OpenSim reports, including where its algorithms are not shortest paths;
///  - kExact: the stationary (shortest) path over each surface on the side OpenSim's rules
///    choose: a helix on the cylinder, a great circle on the sphere, a numerical geodesic on the
///    ellipsoid and the torus, with the straight segments tangent to the surface.
///
/// Moment arms. A WrappedPath gives dL/dx ("pulls", unit-less) at every active path point and at
/// the two tangent points of every wrap that wraps. With x_e(q) the world position of element e
/// (a path point where the kinematics puts it; a tangent point held FIXED in its wrap object's
/// frame S, i.e. a point of the wrap object's link), the generalized force of a unit tension is
///     Q_c = - sum_e pull_e . dx_e/dq_c        (dx_e/dq_c: the point Jacobian of e's link)
/// This is OpenSim's moment arm (MomentArmSolver: the point forces of GeometryPath::
/// produceForces, which put the tangent points on the wrap object's body), and in kExact mode
/// it is also -dL/dq exactly: at a stationary path moving a tangent point along the surface does
/// not change L (envelope theorem), so no finite differences are needed. A muscle that shortens
/// when q_c grows has a positive moment arm Q_c.
///
/// Numerical outcomes never throw and never give NaN: they set WrapStatus bits per wrap and for
/// the path (WrapStatusText says them in words).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench {

// WrapMode (how wrapped paths are computed: kOpenSim, kExact) is in isowrench/model.hpp, as
// LimbDescription::wrap_mode.

/// "opensim" or "exact".
const char* WrapModeName(WrapMode mode);

/// "opensim" or "exact". @throws Error naming the text and the two choices.
WrapMode ParseWrapMode(const std::string& text);

/// OpenSim's answer for one segment and one wrap object (WrapObject::WrapAction).
enum class WrapAction {
  kNoWrap = 0,         ///< the segment misses the object (or is clear on the allowed side)
  kInsideRadius = 1,   ///< an end point is inside the object: no wrap
  kWrapped = 2,        ///< wraps; among several segments the one lengthened least is used
  kMandatoryWrap = 3,  ///< the straight segment goes through the object: this segment wraps
};

/// Bits of WrapSegmentResult::status, WrappedPath::Wrap::status and WrappedPath::status.
enum WrapStatus : unsigned {
  /// The wrapped path from the segment's first point to its last is shorter than the straight
  /// line between them (OpenSim's algorithm; a true wrap is never shorter).
  kWrapBelowStraightLine = 1u << 0,
  /// An iteration stopped at its limit: OpenSim's cylinder tangent adjustment (100 restarts),
  /// the ellipsoid's tangent-point solve (50 iterations) or closest point (64), the torus's
  /// lmdif (500 evaluations), the multi-wrap passes (8 without two lengths within 0.5 mm; exact
  /// mode: 200 without two within 1e-13 m), or the exact geodesic solve.
  kWrapNotConverged = 1u << 1,
  /// OpenSim's arc is negative (a constrained sphere wrapped the far side: WrapSphere::wrapLine
  /// gives -(2 pi - angle) R); the length sums it as OpenSim does.
  kWrapNegativeArc = 1u << 2,
  /// A configuration where OpenSim's algorithm reads a NaN or the previous posture's result
  /// (the segment through a sphere's centre, an ellipsoid closest point that fails, a ray that
  /// misses the ellipsoid): a defined fallback is used instead, never a NaN.
  kWrapDegenerate = 1u << 3,
  /// Exact mode: no stationary path exists on the side OpenSim chose (the straight segment is
  /// already clear on that side, or the geodesic solve failed): OpenSim's path is used.
  kWrapExactFallback = 1u << 4,
  /// A wrap's range holds no active point: OpenSim stops applying this wrap and the wraps after
  /// it in this pass (GeometryPath::applyWrapObjects returns).
  kWrapRangeEmpty = 1u << 5,
};

/// The status bits in words ("" for 0), e.g. "arc negative (OpenSim's far-side sphere wrap)".
std::string WrapStatusText(unsigned status);

/// A wrap surface in its own frame S (the geometry of a WrapObjectSpec without its link).
struct WrapSurface {
  WrapShape shape = WrapShape::kCylinder;
  double radius = 0.0;                              ///< m: cylinder, sphere
  double length = 0.0;                              ///< m: cylinder (along z, centred)
  Eigen::Vector3d radii = Eigen::Vector3d::Zero();  ///< m: ellipsoid semi-axes
  double inner_radius = 0.0;                        ///< m: torus tube
  double outer_radius = 0.0;                        ///< m: torus ring
  WrapQuadrant quadrant;                            ///< constrained side
  /// The surface of a wrap object (its pose and `active` are not part of it).
  static WrapSurface From(const WrapObjectSpec& object);
};

/// One segment wrapped over one surface: the tangent points and the arc between them.
struct WrapSegmentResult {
  WrapAction action = WrapAction::kNoWrap;
  /// The tangent points and the arc are in use: OpenSim inserts them into the path when this
  /// segment is the one chosen (its WrapResult has wrap points).
  bool wraps = false;
  Eigen::Vector3d r1 = Eigen::Vector3d::Zero();  ///< m, in S: the tangent point after p1
  Eigen::Vector3d r2 = Eigen::Vector3d::Zero();  ///< m, in S: the tangent point before p2
  double arc_length = 0.0;                       ///< m, from r1 to r2 over the surface
  unsigned status = 0;                           ///< WrapStatus bits
};

/// Wrap the segment p1 -> p2 (m, both in S) over `surface`: OpenSim's wrapLine (kOpenSim) or
/// the exact stationary path on the side it chooses (kExact). `method` matters for ellipsoids;
/// `single_wrap` is OpenSim's WrapResult::singleWrap (the muscle has exactly one PathWrap,
/// which turns off WrapCylinder's tangent-point adjustment). Never throws.
WrapSegmentResult WrapSegment(const WrapSurface& surface, const Eigen::Vector3d& p1,
                              const Eigen::Vector3d& p2, WrapMode mode,
                              WrapMethod method = WrapMethod::kHybrid, bool single_wrap = true);

/// One wrap of a muscle at one posture, as ComputeWrappedPath needs it.
struct WrapPathWrap {
  WrapSurface surface;
  /// Pose of the surface frame S in world at this posture: X_W_link * WrapObjectSpec::Pose().
  Eigen::Isometry3d X_W_S = Eigen::Isometry3d::Identity();
  /// The range resolved to 0-based point indices (first <= last < point count): OpenSim's
  /// range [first, last] 1-based, -1 = the first/last point (PathWrapSpec), minus 1.
  int first = 0;
  int last = 0;
  WrapMethod method = WrapMethod::kHybrid;
  bool active = true;  ///< WrapObjectSpec::active
  /// Identity of the wrap object (an index into LimbDescription::wrap_objects): two wraps of
  /// one muscle over the same object are "the same wrap object" to OpenSim (no segment between
  /// their tangent points is wrapped, and none adds its straight length). -1: this wrap's own.
  int object = -1;
};

/// A muscle path at one posture: all its points (in MuscleSpec::path order) and its wraps.
struct WrapPathInput {
  std::vector<Eigen::Vector3d> points;  ///< m, world positions of every path point
  std::vector<char> active;             ///< per point: in the path (conditional points)
  std::vector<WrapPathWrap> wraps;      ///< in MuscleSpec::wraps order
};

/// The wrapped path of one muscle at one posture.
struct WrappedPath {
  /// One element of the path in order: a path point (point >= 0) or the tangent point `end`
  /// (0: r1, 1: r2) of wrap `wrap`.
  struct Element {
    int point = -1;
    int wrap = -1;
    int end = 0;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, world
  };
  /// What one wrap did.
  struct Wrap {
    bool wrapped = false;  ///< its tangent points are in the path
    WrapAction action = WrapAction::kNoWrap;
    /// The segment it wraps: path points first_point -> ... (the elements between the two
    /// tangent points' neighbours); -1 when not wrapped.
    Eigen::Vector3d r1_S = Eigen::Vector3d::Zero();  ///< m, tangent points in S
    Eigen::Vector3d r2_S = Eigen::Vector3d::Zero();
    Eigen::Vector3d r1 = Eigen::Vector3d::Zero();  ///< m, the same in world
    Eigen::Vector3d r2 = Eigen::Vector3d::Zero();
    /// dL/dx at r1 and r2 (world): -u_in at r1 (u_in the unit direction of the straight segment
    /// arriving at r1) and +u_out at r2 (u_out leaving r2); the r1 -> r2 arc pulls nothing.
    Eigen::Vector3d pull_r1 = Eigen::Vector3d::Zero();
    Eigen::Vector3d pull_r2 = Eigen::Vector3d::Zero();
    double arc_length = 0.0;  ///< m
    unsigned status = 0;      ///< WrapStatus bits of its chosen segment
  };
  double length = 0.0;            ///< m: straight segments plus arcs
  std::vector<Element> elements;  ///< the path, origin first
  /// dL/dx of each path point (world; MuscleSpec::path order): the sum of the unit directions of
  /// its straight segments (u_in - u_out); zero for inactive points.
  std::vector<Eigen::Vector3d> point_pull;
  std::vector<Wrap> wraps;  ///< per WrapPathInput::wraps entry
  unsigned status = 0;      ///< the union of the wraps' status bits and the path's own
  int passes = 0;           ///< passes of GeometryPath::applyWrapObjects (1 to 8)
};

/// Compute the wrapped path (GeometryPath::applyWrapObjects, then its length as
/// calcLengthAfterPathComputation; docs/opensim.md "Wrapping"). Reuses `out`'s storage: after
/// the first call with a given muscle, further calls do not allocate. Never throws for
/// numerical reasons; @throws Error for inconsistent input (sizes, a range out of bounds).
void ComputeWrappedPath(const WrapPathInput& input, WrapMode mode, WrappedPath& out);

/// Check the wrap objects and the muscles' wrap lists of a description: positive finite
/// dimensions, a torus whose inner radius is below its outer one, known links, unique names,
/// wraps naming existing objects, ranges inside the path (1-based, -1 = end, first <= last).
/// Model construction calls it. @throws Error naming the model, the muscle and the object.
void CheckWraps(const LimbDescription& description, const std::string& model_name);

}  // namespace isowrench
