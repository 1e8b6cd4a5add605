#pragma once
/// @file
/// Limb models: the editable description read from URDF (+ isowrench extension tags), and the
/// immutable Model built from it (KDL chain, joint roles and stiffnesses, muscles, transducer).
///
/// URDF extension tags are documented in docs/urdf-extensions.md. In short, inside <robot>:
///   <isowrench:joint name="knee_ry" role="extra" stiffness="1.0"/>
///   <isowrench:transducer link="tibia" xyz="0.041 0 0" rpy="0 0 0" axes="world"
///                         stiffness="1e7 1e7 1e7 1e7 1e7 1e7" released="rz"/>
///   <isowrench:muscle name="GP" max_force="2.3">
///     <isowrench:point link="ground" xyz="..."/> <isowrench:point link="tibia" xyz="..."/>
///   </isowrench:muscle>
///   <isowrench:posture joint="hip_rz" degrees="-110"/>
///   <isowrench:coordinate name="knee_angle" type="revolute" default="0.3" lower="-2" upper="0.2"/>
///   <isowrench:coupling joint="knee_tx" coordinate="knee_angle"> FUNCTION </isowrench:coupling>
/// and the standard URDF <mimic joint="knee_rz" multiplier="0.01" offset="0.002"/> in a joint.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <initializer_list>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "isowrench/function.hpp"
#include "isowrench/muscle.hpp"

namespace isowrench {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// A joint-space vector: one entry per coordinate (column) of a Model, any number of them.
/// A Data holds its vectors from construction on (sized from the Model, never resized), so an
/// evaluation never allocates.
using JointVector = Eigen::VectorXd;
/// An m x r joint-space matrix (any m, r).
using JointMatrix = Eigen::MatrixXd;
/// A 6 x m endpoint Jacobian (any m).
using JacobianBuffer = Matrix6Xd;
/// A read-only view of a joint-space vector a Data holds (Data::tau(), dtheta(), ...): it shows
/// the Data's buffer, so it stays valid as long as the Data and shows the last evaluation.
using JointVectorView = Eigen::Map<const JointVector>;
/// A read-only view of an m x r matrix a Data holds (Data::self_motion()), as JointVectorView.
using JointMatrixView = Eigen::Map<const JointMatrix>;

/// One set of compliances for the statics.
struct StiffnessSet {
  /// S_t diagonal in transducer axes [kx ky kz krx kry krz] (N/m, N·m/rad), each >= 0; a zero
  /// entry is a released dof (docs/model.md "Released dofs").
  Vector6d s_t = Vector6d::Zero();
  /// S_p diagonal, one entry per movable joint in column order (N·m/rad or N/m), each >= 0.
  JointVector s_p;
};

/// Joint kinds isowrench represents. URDF "continuous" becomes kRevolute; "fixed" joints are
/// folded into the chain; "floating" and "planar" are refused with an Error.
enum class JointType { kRevolute, kPrismatic, kFixed };

/// What a movable joint stands for. Roles only label results and choose defaults; the
/// mechanics is the same for all (a joint with a stiffness in S_p).
enum class JointRole {
  kLimb,     ///< an ordinary limb dof (stiffness usually 0)
  kBase,     ///< a base translation dof modelling imperfect skeletal fixation
  kExtra,    ///< an extra joint dof held by a passive stiffness (e.g. knee ab/adduction)
  kRelease,  ///< a released transducer dof written as an explicit zero-stiffness joint
};

/// Name of a role as used in URDF tags: "limb", "base", "extra", "release".
const char* RoleName(JointRole role);

/// One joint of the chain, in URDF semantics: child pose = origin * motion(axis, q).
struct JointSpec {
  std::string name;
  JointType type = JointType::kRevolute;
  std::string parent_link;
  std::string child_link;
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  ///< parent link -> joint frame at q=0
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();           ///< unit axis in the joint frame
  JointRole role = JointRole::kLimb;
  /// N·m/rad (revolute) or N/m (prismatic), >= 0. For a joint that carries its own coordinate
  /// (coordinate == name, identity coupling) this is the coordinate's S_p entry, and it and
  /// `role` are copied onto the CoordinateSpec by NormalizeCoordinates(). A driven joint
  /// (another coordinate, or a non-identity coupling) has no dof of its own: stiffness 0.
  double stiffness = 0.0;
  /// The independent coordinate driving this movable joint (a CoordinateSpec name). Empty means
  /// "the joint's own coordinate" (coordinate = name, identity coupling); NormalizeCoordinates()
  /// fills it. Unused for fixed joints.
  std::string coordinate;
  /// q_joint = coupling(q_coordinate), in rad or m on both sides. Identity = Linear(1, 0).
  Function coupling = Function::Linear(1.0, 0.0);
};

/// One independent coordinate: one public column of the Jacobian, of the moment arms and of
/// S_p, and one entry of a posture. Most coordinates are carried by one movable joint with the
/// identity (`joint` == `name`); a free-standing coordinate (`joint` empty, URDF
/// <isowrench:coordinate>) only drives other joints through their couplings.
struct CoordinateSpec {
  std::string name;
  JointType type = JointType::kRevolute;  ///< kRevolute (rad) or kPrismatic (m)
  JointRole role = JointRole::kLimb;
  double stiffness = 0.0;      ///< S_p entry: N·m/rad (revolute) or N/m (prismatic), >= 0
  double default_value = 0.0;  ///< rad or m; the nominal posture unless nominal_posture names it
  double lower = -std::numeric_limits<double>::infinity();  ///< rad or m (informative)
  double upper = std::numeric_limits<double>::infinity();   ///< rad or m (informative)
  /// Held rigid by the statics (excluded from the stiffness matrix, no displacement there), but
  /// still a column of J and of the moment arms and settable in postures.
  bool locked = false;
  /// The movable joint carrying this coordinate with the identity, or "" (free-standing).
  std::string joint;
};

/// One component of a moving path point (OpenSim MovingPathPoint): component `axis` of the
/// point's position in its link's frame is `function`(clamp(q, lower, upper)) metres, with q
/// the value of independent coordinate `coordinate` and lower/upper its range
/// (CoordinateSpec::lower/upper; no clamp where they are infinite). OpenSim clamps the same way
/// (MovingPathPoint::getLocation, OpenSim 4.0-4.5). The derivative of the component is
/// function'(q) inside [lower, upper] and 0 outside, so dL/dq is the derivative of the length.
struct MovingComponent {
  int axis = 0;            ///< 0, 1, 2: x, y, z of the link frame
  std::string coordinate;  ///< an independent coordinate (CoordinateSpec name)
  Function function;       ///< m as a function of the coordinate (rad or m)
};

/// A muscle path point on a link ("ground" = the root link, i.e. fixed in world). Fixed by
/// default; `moving` replaces components of `position` by functions of coordinates; a non-empty
/// `active_coordinate` makes the point conditional (OpenSim ConditionalPathPoint): it is in the
/// path only while active_lower - 1e-5 <= q <= active_upper + 1e-5 (OpenSim's tolerance, in rad
/// or m), otherwise the path goes straight from the previous active point to the next.
struct PathPoint {
  PathPoint() = default;
  /// A fixed point: `position` (m) in `link`'s frame.
  PathPoint(std::string link_name, const Eigen::Vector3d& link_position)
      : link(std::move(link_name)), position(link_position) {}

  std::string link;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, in the link's frame
  /// Moving components, at most one per axis (the other components are `position`'s).
  std::vector<MovingComponent> moving;
  /// Conditional point: the coordinate and range (rad or m, lower <= upper) it is active in.
  std::string active_coordinate;
  double active_lower = 0.0;
  double active_upper = 0.0;
};

/// OpenSim's tolerance on a ConditionalPathPoint's range (rad or m): active while
/// lower - kActiveRangeTolerance <= q <= upper + kActiveRangeTolerance.
inline constexpr double kActiveRangeTolerance = 1e-5;

// ---- Wrapping (OpenSim wrap objects; docs/opensim.md "Wrapping", include/isowrench/wrap.hpp) ----

/// Shape of a wrap object: OpenSim's WrapCylinder, WrapSphere, WrapEllipsoid, WrapTorus.
enum class WrapShape { kCylinder, kSphere, kEllipsoid, kTorus };

/// "cylinder", "sphere", "ellipsoid", "torus" (the URDF spelling, <isowrench:wrap shape=>).
const char* WrapShapeName(WrapShape shape);

/// OpenSim's `quadrant` of a wrap object: the side a path may wrap over. `sign` 0 is "all"
/// (unconstrained); otherwise the path wraps over the half where coordinate `axis` (0, 1, 2:
/// x, y, z of the wrap object's frame) has sign `sign` (WrapObject::extendFinalizeFromProperties).
struct WrapQuadrant {
  int axis = 0;  ///< 0, 1, 2 (unused when sign is 0)
  int sign = 0;  ///< +1, -1, or 0 for "all"
  /// OpenSim's spellings: "all", "All", "ALL", "x", "+x", "X", "+X", "-x", "-X" (y, z alike).
  /// @throws Error naming the text for anything else.
  static WrapQuadrant Parse(const std::string& text);
  /// "all", "+x", "-y", ...
  std::string ToString() const;
  bool operator==(const WrapQuadrant& other) const {
    return sign == other.sign && (sign == 0 || axis == other.axis);
  }
};

/// A wrap object fixed on a link (OpenSim: an entry of a body's WrapObjectSet). Its frame S is
/// `translation` (m, in the link's frame) and the body-fixed X-Y-Z rotation `xyz_body_rotation`
/// (rad; Simbody Rotation::setRotationToBodyFixedXYZ, as OpenSim's WrapObject::_pose), so
/// X_link_S = [BodyFixedXyz(xyz_body_rotation), translation]. Dimensions by shape, in S: a
/// cylinder of `radius` about the z axis, `length` along z centred on the origin; a sphere of
/// `radius`; an ellipsoid with semi-axes `radii` along x, y, z; a torus about the z axis whose
/// tube of radius `inner_radius` circles the origin at `outer_radius` in the xy plane.
struct WrapObjectSpec {
  std::string name;
  std::string link;  ///< a link of the chain, or the root link (fixed in world)
  WrapShape shape = WrapShape::kCylinder;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();        ///< m, in the link's frame
  Eigen::Vector3d xyz_body_rotation = Eigen::Vector3d::Zero();  ///< rad, body-fixed X-Y-Z
  double radius = 0.0;                                          ///< m: cylinder, sphere; > 0
  double length = 0.0;                              ///< m: cylinder, > 0 (OpenSim: >= 0)
  Eigen::Vector3d radii = Eigen::Vector3d::Zero();  ///< m: ellipsoid semi-axes, each > 0
  double inner_radius = 0.0;                        ///< m: torus tube radius, > 0
  double outer_radius = 0.0;                        ///< m: torus ring radius, > inner_radius
  bool active = true;                               ///< false: never wraps (OpenSim `active`)
  WrapQuadrant quadrant;                            ///< constrained side ("all" by default)
  /// X_link_S: the object's frame in its link's frame.
  Eigen::Isometry3d Pose() const;
};

/// OpenSim's PathWrap `method`; it matters for ellipsoids only (WrapEllipsoid::wrapLine).
enum class WrapMethod { kHybrid, kMidpoint, kAxial };

/// "hybrid", "midpoint", "axial".
const char* WrapMethodName(WrapMethod method);

/// How the engine computes paths over wrap objects (include/isowrench/wrap.hpp; docs/opensim.md
/// "Wrapping"): kOpenSim, OpenSim 4.x's algorithms as written (lengths and MomentArmSolver moment
/// arms as OpenSim reports them); kExact, the stationary (shortest) path on the side OpenSim's
/// rules choose, with moment arms = -dL/dq exactly.
enum class WrapMode { kOpenSim, kExact };

/// One entry of a muscle's wrap list (OpenSim: a PathWrap of the GeometryPath's PathWrapSet).
/// Wraps apply in list order (GeometryPath::applyWrapObjects). `range_first`/`range_last` are
/// OpenSim's `range`: 1-based numbers of the muscle's path points (MuscleSpec::path, inactive
/// conditional points counted), -1 meaning the first / the last point; the wrap acts on one
/// segment between the active points of that range (docs/opensim.md "Wrapping").
struct PathWrapSpec {
  std::string object;  ///< a WrapObjectSpec name
  int range_first = -1;
  int range_last = -1;
  WrapMethod method = WrapMethod::kHybrid;
};

/// A muscle through its active path points (origin first, insertion last), straight between
/// them except where a wrap object of `wraps` bends it.
struct MuscleSpec {
  std::string name;
  /// N, > 0: OpenSim's max_isometric_force; with the constant force model, the force at
  /// activation 1.
  double max_force = 0.0;
  std::vector<PathPoint> path;  ///< at least two points, of which at least two never inactive
  /// Wrap objects the path wraps over, in the order they apply (empty: a straight path).
  std::vector<PathWrapSpec> wraps;
  /// The force model and its parameters (muscle.hpp; default: constant, F = a * max_force).
  MuscleForceSpec force;
};

/// Index into a 6-vector in KDL order: x y z rx ry rz.
enum Dof : int { kX = 0, kY = 1, kZ = 2, kRX = 3, kRY = 4, kRZ = 5 };

/// Name of a 6-vector component ("x", "y", "z", "rx", "ry", "rz").
const char* DofName(int dof);

/// A set of the 6 transducer dofs (x y z rx ry rz, transducer axes): the one way isowrench says
/// which dofs are released (TransducerSpec::released, WithReleasedDofs, ClassicWrench) or
/// restrained (~released). Spelled "rz", "rx,ry" or "rx ry" in files and on the command line.
class DofMask {
 public:
  /// The empty set.
  DofMask() = default;
  /// The named dofs: DofMask{"rz", "x"}. @throws Error naming a name that is not a dof.
  DofMask(std::initializer_list<std::string> names);
  /// The named dofs ("none" names nothing). @throws Error naming a name that is not a dof.
  static DofMask FromNames(const std::vector<std::string>& names);
  /// "rz", "rx,ry", "rx ry", "" or "none". @throws Error naming the token that is not a dof.
  static DofMask Parse(const std::string& text);
  /// All six dofs.
  static DofMask All() { return FromBits(0x3f); }
  /// Bit i set: dof i (Dof order) is in the set.
  static DofMask FromBits(unsigned bits) { return DofMask(bits & 0x3fu); }

  /// True when dof `dof` (0..5, Dof order) is in the set.
  bool operator[](int dof) const { return ((bits_ >> dof) & 1u) != 0; }
  /// Add (value true) or remove dof `dof`; returns *this.
  DofMask& set(int dof, bool value = true) {
    bits_ = value ? (bits_ | (1u << dof)) : (bits_ & ~(1u << dof));
    return *this;
  }
  /// The complement: the restrained dofs of a released set and vice versa.
  DofMask operator~() const { return DofMask(~bits_ & 0x3fu); }
  unsigned bits() const { return bits_; }
  int count() const;
  bool any() const { return bits_ != 0; }
  bool none() const { return bits_ == 0; }
  /// Names in Dof order ({} for the empty set).
  std::vector<std::string> names() const;
  /// Names joined by `separator` ("rx,ry"), "none" for the empty set.
  std::string ToString(const std::string& separator = ",") const;
  bool operator==(const DofMask& other) const { return bits_ == other.bits_; }
  bool operator!=(const DofMask& other) const { return bits_ != other.bits_; }

 private:
  explicit DofMask(unsigned bits) : bits_(bits) {}
  unsigned bits_ = 0;
};

/// The endpoint and the transducer it is bolted to.
struct TransducerSpec {
  std::string link;                                    ///< the distal link carrying the endpoint
  Eigen::Vector3d endpoint = Eigen::Vector3d::Zero();  ///< m, endpoint origin in `link`'s frame
  /// Orientation of the transducer axes: in world (axes_in_world = true, the transducer is
  /// bolted to ground) or relative to `link` (false, the axes turn with the distal bone).
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  bool axes_in_world = true;
  /// S_t diagonal in transducer axes [kx ky kz krx kry krz]; N/m then N·m/rad; each >= 0.
  Vector6d stiffness = Vector6d::Constant(1e7);
  /// Released dofs of the transducer (rows deleted from J and S_t), in transducer axes.
  DofMask released;
};

/// Transducer stiffness presets from docs/model.md "Transducer stiffness presets".
/// Names: "balanced" (1e7 everywhere), "ati-mini40", "jr3" (as printed in the paper).
/// @throws Error for an unknown name (the message lists the known ones).
Vector6d TransducerPreset(const std::string& name);

/// The full, editable description of a limb: everything a URDF with isowrench tags says.
/// Only the joints on the path from the root link to the endpoint link are kept.
struct LimbDescription {
  std::string name;                ///< robot name
  std::string source;              ///< file the description came from ("" when built in code)
  std::string root_link;           ///< the ground link
  std::vector<std::string> links;  ///< root first, then each joint's child link
  std::vector<JointSpec> joints;   ///< chain order, root to endpoint, fixed joints included
  std::vector<MuscleSpec> muscles;
  TransducerSpec transducer;
  /// Independent coordinates in column order (see CoordinateSpec). ReadUrdfFile fills them;
  /// a description built in code may leave them empty: NormalizeCoordinates() then gives every
  /// movable joint its own coordinate, in chain order.
  std::vector<CoordinateSpec> coordinates;
  /// Nominal posture: coordinate name -> position (rad or m). Coordinates not named here are at
  /// their default_value (0 unless an <isowrench:coordinate default=> says otherwise).
  std::vector<std::pair<std::string, double>> nominal_posture;
  /// Wrap objects on the links (OpenSim WrapObjectSets), named by MuscleSpec::wraps.
  std::vector<WrapObjectSpec> wrap_objects;
  /// How every length, moment arm, torque and wrench of the model computes the muscles' wraps
  /// (the URDF's `<robot isowrench:wrap_mode=...>`, kOpenSim when absent; the --wrap option
  /// and Python wrap= override it: ModelOverrides::wrap). WriteUrdfString writes it.
  WrapMode wrap_mode = WrapMode::kOpenSim;
};

/// The coordinate called `name`.
/// @throws Error for a driven joint ("joint 'knee_tx' is driven by coordinate 'knee_rz' (mimic);
///         set 'knee_rz' instead"), a fixed joint, or an unknown name (with the closest name).
const CoordinateSpec& FindCoordinate(const LimbDescription& description, const std::string& name);

/// Make `coordinates` consistent with `joints` (a copy is returned; idempotent):
///  - a movable joint with an empty `coordinate` gets its own (coordinate = its name, identity);
///  - a joint that carries its own coordinate (coordinate == name, identity coupling) has a
///    CoordinateSpec with joint = its name, whose type, role and stiffness are the joint's;
///  - coordinates carried by a joint that is gone or no longer movable are dropped, unless
///    another joint is driven by them (they become free-standing);
///  - the order is that of the first joint each coordinate carries or drives, along the
///    chain; free-standing coordinates that drive nothing come last.
/// The description edits and ReadUrdfFile call it; Model calls it for descriptions built in code.
/// @throws Error for a joint driven by an unknown coordinate, a joint coupled to itself, a
///         driven joint with a non-zero stiffness, or an invalid free-standing coordinate
///         (fixed type, stiffness not finite or negative, default not finite, lower > upper).
LimbDescription NormalizeCoordinates(LimbDescription description);

/// Parse a URDF file with isowrench extension tags.
/// @throws Error naming the file and line for malformed XML, unsupported joint types
///         (floating, planar), unknown links/joints in tags, non-finite or negative values.
LimbDescription ReadUrdfFile(const std::string& path);

/// Same as ReadUrdfFile for text already in memory; `source_name` appears in messages.
LimbDescription ReadUrdfString(const std::string& xml, const std::string& source_name);

/// Serialize a description back to URDF text with isowrench tags (round-trips through
/// ReadUrdfString to an equal description).
std::string WriteUrdfString(const LimbDescription& description);

/// Write WriteUrdfString() to `path` atomically (temporary file, then rename).
/// @throws Error if the file cannot be written.
void WriteUrdfFile(const LimbDescription& description, const std::string& path);

// ---- Editing a description (each returns a modified copy; all throw Error on bad names) ----

/// Add three prismatic joints base_x, base_y, base_z (world axes, role kBase) between the
/// root link and the first joint, each with `stiffness` N/m. If the description already has
/// base joints their stiffness is set instead.
LimbDescription WithBaseStiffness(LimbDescription description, double stiffness);

/// Set the S_p stiffness of a named coordinate (N·m/rad or N/m, >= 0); a joint that carries
/// its own coordinate is named by its joint name. @throws Error for a driven joint (see
/// FindCoordinate).
LimbDescription WithJointStiffness(LimbDescription description, const std::string& joint,
                                   double stiffness);

/// Insert an extra revolute joint (role kExtra) right after `after_joint`, turning about
/// `axis` (unit, in the child frame of `after_joint`), with `stiffness` N·m/rad.
LimbDescription WithExtraJoint(LimbDescription description, const std::string& after_joint,
                               const std::string& new_joint, const Eigen::Vector3d& axis,
                               double stiffness);

/// Lock exactly the named coordinates (CoordinateSpec::locked: held rigid by the statics,
/// StaticsProblem) and unlock every other one, like WithReleasedDofs replaces the released set:
/// {} or {"none"} unlocks all. A joint carrying its own coordinate is named by its joint name.
/// @throws Error naming an unknown or driven name (see FindCoordinate).
LimbDescription WithLockedCoordinates(LimbDescription description,
                                      const std::vector<std::string>& locked);

/// Set the transducer's released dofs to `released` (the empty set: none released), e.g.
/// WithReleasedDofs(d, {"rz"}) or WithReleasedDofs(d, DofMask::Parse("rx,ry")).
LimbDescription WithReleasedDofs(LimbDescription description, const DofMask& released);

/// Replace the S_t diagonal (each entry finite and >= 0).
LimbDescription WithTransducerStiffness(LimbDescription description, const Vector6d& stiffness);

/// Immutable model built from a description: validated, and its chain compiled to the flat
/// structure every kinematics and statics evaluation runs on (one engine: the kinematics
/// functions, EvaluateWrench, Evaluate and EvaluateBatch). Its columns are the independent
/// coordinates (LimbDescription::coordinates): each movable joint is driven by one of them,
/// q_joint = coupling(q_coordinate), and results are J = J_joints C, tau = C^T tau_joints with
/// C = dq_joint/dq. Cheap to copy (shared state). Thread-safe to share; mutable scratch lives
/// in a Data, one per thread.
class Model {
 public:
  /// Validate and build. @throws Error naming the joint/link/muscle for any invalid entry.
  explicit Model(LimbDescription description);

  /// ReadUrdfFile + Model.
  static Model FromUrdfFile(const std::string& path);

  const LimbDescription& description() const;
  const std::string& name() const { return description().name; }

  /// Number of independent coordinates m: the column count of J, tau, S_p and postures (the
  /// number of movable joints when nothing is coupled).
  int dof_count() const;
  /// Coordinate names in column order (a joint carrying its own coordinate gives its name).
  const std::vector<std::string>& joint_names() const;
  /// Spec of column i: the movable joint carrying coordinate i, or for a free-standing
  /// coordinate a JointSpec with its name (links: those of the last joint it drives). Type,
  /// role and stiffness are always the coordinate's.
  const JointSpec& joint(int i) const;
  /// Independent coordinate i (column i).
  const CoordinateSpec& coordinate(int i) const;
  /// Column of a coordinate. @throws Error for a driven joint (naming its driver) or an unknown
  /// name (see FindCoordinate).
  int JointIndex(const std::string& name) const;
  /// S_p diagonal in column order (N·m/rad or N/m): the coordinates' stiffnesses.
  Eigen::VectorXd joint_stiffness() const;

  int muscle_count() const;
  const MuscleSpec& muscle(int i) const;
  /// @throws Error listing the known muscles.
  int MuscleIndex(const std::string& name) const;

  const TransducerSpec& transducer() const { return description().transducer; }

  /// Nominal posture in column order (rad / m): each coordinate's default_value, overridden by
  /// LimbDescription::nominal_posture.
  Eigen::VectorXd nominal_posture() const;

  /// Leg length (m): the length of the limb from the first revolute joint's centre through each
  /// revolute joint's centre, in chain order, to the endpoint, at the nominal posture (for the
  /// rat: hip to knee to ankle), whatever fixed offsets or coupled translations carry the
  /// centres; fixed offsets before the first movable joint (a clamp) do not count
  /// (docs/model.md "Leg length"). The small-motion rule and the diagnostics' length scale are
  /// relative to it (StaticsProblem::leg_length()).
  double chain_length() const;

  /// True for revolute columns, false for prismatic ones. @throws std::out_of_range.
  bool revolute(int column) const;

  /// The model's own compliances: S_t from the transducer spec with released dofs set to 0,
  /// S_p from the coordinates' stiffnesses (the StiffnessSet of engine.hpp).
  const StiffnessSet& model_stiffness() const;

  /// Opaque access for isowrench's own modules (the compiled chain). Not part of the stable API.
  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Impl> impl_;
};

/// Mutable scratch of the engine for one thread (the Model/Data split: the Model is shared,
/// each thread owns a Data). Evaluations leave their results here (the last evaluation's
/// Jacobian, torque, displacement and self-motion basis stay readable until the next one).
/// Construction allocates once, every buffer sized from the model (its movable joints,
/// coordinates, coupled joints and path points: there is no fixed limit on any of them);
/// evaluations never allocate. Never share one between threads. A Data evaluates the model it
/// was made for (and copies of it); given another model it is checked first, and a model it is
/// too small for (or with another number of coordinates) is refused with an Error.
class Data {
 public:
  /// Workspace sized for `model`.
  explicit Data(const Model& model);
  /// Workspace for the raw-matrix solve SolveStatics(Data&, J, ...) with `dof_count` joints
  /// (any number >= 1). @throws Error if dof_count < 1.
  explicit Data(int dof_count);
  ~Data();
  Data(Data&&) noexcept;
  Data& operator=(Data&&) noexcept;

  /// J_T_E (6 x m) of the last ComputeKinematics: rows [v; w] in transducer axes,
  /// reference point the endpoint origin (m/rad, m/m, rad/rad). The engine keeps J row by row;
  /// this is a column-major copy made on each call, so a reference kept across the next
  /// evaluation still shows the old J: call jacobian() again. Like every use of a Data (one per
  /// thread), not to be called from two threads at once.
  const JacobianBuffer& jacobian() const;
  /// Muscle torque tau = -F (dL/dtheta)^T of the last kinematics (N·m or N per joint); a view
  /// of the Data's buffer (JointVectorView).
  JointVectorView tau() const;
  /// dL/dtheta of the last kinematics (m/rad or m/m per joint); a view, as tau().
  JointVectorView muscle_length_gradient() const;
  /// Muscle length (m) of the last kinematics.
  double muscle_length() const;
  /// Endpoint position in world (m) of the last kinematics. Like jacobian(), a copy made on
  /// each call (the engine keeps it in its own layout): a reference kept across the next
  /// evaluation still shows the old position.
  const Eigen::Vector3d& endpoint_position() const;
  /// R_W_T of the last kinematics: transducer axes in world. A copy made on each call, as
  /// endpoint_position().
  const Eigen::Matrix3d& transducer_rotation() const;
  /// dtheta of the last solve (rad or m per joint); zeros after kSelfMotion / kInvalidInput. A
  /// view, as tau().
  JointVectorView dtheta() const;
  /// Self-motion basis of the last solve: m x r, unit columns spanning null(K), largest entry
  /// positive (the same convention as StaticsResult::self_motion); r = 0 when K is regular. A
  /// view of the Data's buffer (JointMatrixView): copy it to keep it across evaluations.
  JointMatrixView self_motion() const;

  /// Opaque access for isowrench's own modules (the kernel's buffers). Not part of the stable API.
  struct Impl;
  Impl& impl() { return *impl_; }
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace isowrench
