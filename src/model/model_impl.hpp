#pragma once
// Private: what a Model holds besides its description: the chain compiled to a flat structure,
// the one form every kinematics and statics evaluation runs on (src/fast/fast.cpp for scalars,
// src/fast/lanes.cpp for the SIMD lanes of the batch).

#include <cstdint>
#include <kdl/chain.hpp>
#include <map>
#include <string>
#include <vector>

#include "isowrench/function.hpp"
#include "isowrench/model.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/wrap.hpp"
#include "model/function_impl.hpp"

namespace isowrench {

/// n rounded up to a multiple of 4: the engine reads and writes rows of J, dL/dq and tau in whole
/// 4-double vectors, so its buffers of n columns hold this many.
inline constexpr int RoundUpTo4(int n) { return (n + 3) / 4 * 4; }

/// The engine's workspaces come in two shapes (src/fast/fast_impl.hpp). A chain of at most
/// kSmallJoints movable joints and columns, at most kSmallSlots - kSmallJoints driven joints
/// and kSmallPoints path points per muscle runs on fixed-size arrays inside its workspace, whose
/// strides and offsets are compile-time constants (the kernel's small chains: every shipped
/// model); any larger chain runs on buffers sized from it (FlatChain::large), with no limit.
inline constexpr int kSmallJoints = 16;
inline constexpr int kSmallSlots = 2 * kSmallJoints;
inline constexpr int kSmallPoints = 64;

/// One movable joint, relative to the frame after the previous movable joint (world for the
/// first one), with the fixed joints in between folded into `origin_*`.
struct FastJoint {
  Eigen::Matrix3d origin_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< unit, in the joint frame
  bool revolute = true;
  /// The joint's kind, the case of the kernel's joint step (JointStep): revolute (1) | axis
  /// kind << 1 (0/1/2: +-x/y/z, a specialised rotation; 3: a general axis) | a fixed translation
  /// before it (8) | a fixed rotation before it (16) | a negative coordinate axis (32).
  int op = 0;
};

/// A muscle path point in the frame after movable joint `frame` (-1 = world).
struct FastPathPoint {
  int frame = -1;
  /// m, in that frame; for a moving point, with its moving components taken as 0.
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  /// Conditional point: the column of its coordinate (-1: always in the path) and the range
  /// it is in the path for, OpenSim's 1e-5 tolerance included.
  int active_column = -1;
  double active_lower = 0.0;
  double active_upper = 0.0;
};

/// One moving component (PathPoint::moving) of point `point`: in the point's frame the point
/// is FastPathPoint::position + direction * function(clamp(q[column], lower, upper)).
struct FastMovingComponent {
  int point = 0;
  int column = 0;
  Function function;
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();  ///< the link axis in the point's frame
  double lower = 0.0, upper = 0.0;                      ///< the coordinate's range (rad or m)
};

/// One wrap of a muscle (MuscleSpec::wraps entry), compiled: the surface, its resolved range and
/// the two tangent-point slots it owns among the muscle's points. The slots are points of the
/// wrap object's frame (FastMuscle::points[slot], [slot + 1]) placed at the origin of S: the
/// kernel's forward loop gives their world position and frame rotation (X_W_S, with `rotation`),
/// the wrap (src/fast/path_points.cpp, WrappedPathPulls) puts the tangent points r1, r2 and their
/// pulls there, and the backward sweep adds them to the joints proximal to the wrap's link: the
/// tangent points held fixed in S (include/isowrench/wrap.hpp, "Moment arms").
struct FastWrap {
  WrapPathWrap wrap;  ///< surface, range (0-based), method, active, object; X_W_S set per posture
  int slot = 0;       ///< r1 at points[slot], r2 at points[slot + 1]
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< R of S in the slots' frame
};

struct FastMuscle {
  double max_force = 0.0;
  /// The force stage (docs/muscle.md "In the engine"): the muscle's force model, compiled once
  /// when the Model is built; MuscleForceAt (engine.hpp) evaluates it. `force_curve` false:
  /// the constant model, F = a * max_force, multiplied into tau inside the kernel as it always
  /// was; true: the kernel runs with a unit force and tau is scaled by F(L_MT, a) after the
  /// path stage (ApplyForceStage, src/fast/fast.cpp; per lane in src/fast/lanes.cpp).
  MuscleForceModel force_model;
  bool force_curve = false;
  /// dynamic || force_curve: the evaluation runs DynamicKinematics (out of line) instead of
  /// the plain kernel (src/fast/fast.cpp), one test for both.
  bool special = false;
  /// Path points (MuscleSpec::path order), then two tangent-point slots per wrap (FastWrap).
  std::vector<FastPathPoint> points;  ///< path order
  /// The muscle's path points (MuscleSpec::path.size()): points[0 .. path_points - 1].
  int path_points = 0;
  /// Its wraps (MuscleSpec::wraps order); non-empty makes the muscle `dynamic`.
  std::vector<FastWrap> wraps;
  /// How its wraps are computed (LimbDescription::wrap_mode).
  WrapMode wrap_mode = WrapMode::kOpenSim;
  std::vector<int> ground_points;  ///< the points on ground (frame -1)
  /// The points of each frame for the kernel's two joint loops: groups {frame, count, the
  /// count point indices} for the frames that have points (ground points left out), in
  /// ascending frame order ended by the sentinel frame FlatChain::m (forward_points) and in
  /// descending order ended by -1 (backward_points). A loop compares its joint with the next
  /// group's frame, one pointer for all the muscle's points.
  std::vector<int> forward_points;
  std::vector<int> backward_points;
  /// backward_points for the kernel's kWrap instantiation (one_cylinder): the wrap's two
  /// tangent-point slots left out, the cylinder's frame kept (a group of count 0 when it has no
  /// other point); the path stage gives the slots' summed pull and moment, which the sweep adds
  /// at that frame's group.
  std::vector<int> one_cylinder_backward_points;
  /// Moving components of its points; `dynamic`: some point moves or is conditional, and each
  /// evaluation first runs PreparePathPoints (src/fast/path_points.cpp).
  std::vector<FastMovingComponent> moving;
  bool dynamic = false;
  /// One active cylinder and fixed points (one wrap, a WrapCylinder, no moving or conditional
  /// point): a small chain's evaluation runs the kernel's kWrap instantiation and its path stage
  /// OneCylinderPathPulls (src/fast/path_points.cpp) instead of the kDynamic ones. `wrap_frame`:
  /// the movable-joint frame of the cylinder's link (-1: world).
  bool one_cylinder = false;
  int wrap_frame = -1;
};

/// A link's frame: the frame after movable joint `frame` (-1 = world) times `offset` (the
/// fixed joints after it folded in).
struct LinkFrame {
  int frame = -1;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
};

/// The chain compiled to flat arrays: per movable joint its fixed transform from the previous
/// movable joint's frame (fixed joints folded in), axis and type; per muscle path point its
/// movable-joint frame and offset; the endpoint and transducer axes.
struct FlatChain {
  /// Unique to this compiled chain (a process-wide counter, from 1): a Data made for it
  /// recognises it by one comparison. And the model's name, for messages.
  std::uint64_t id = 0;
  std::string name;
  int m = 0;  ///< movable joints
  int n = 0;  ///< independent coordinates: the public columns (J, tau, S_p, postures)
  std::vector<FastJoint> joints;
  /// One posture computes sin and cos of joints trig_begin .. trig_end - 1, four at a time: the
  /// revolute joints, widened towards the start to whole groups of 4 where possible (empty
  /// when no joint is revolute).
  int trig_begin = 0;
  int trig_end = 0;
  /// Per movable joint: 1 revolute, 0 prismatic (the backward sweep's test on a large chain);
  /// a small chain's in bits (bit k: movable joint k is revolute).
  std::vector<std::uint8_t> revolute;
  std::uint32_t revolute_mask = 0;
  /// Per movable joint: the column of its coordinate and q_joint = coupling(q_column).
  std::vector<int> coordinate;
  std::vector<Function> coupling;
  /// Coupled chains: per movable joint, where the backward sweep writes its column of J and its
  /// dL/dq (one posture's staging, the lanes' J and tau): the column of its coordinate when the
  /// joint owns it (the first joint of that column with the identity coupling), else a slot
  /// stride + e (e = 0, 1, ...), so that the sweep is the same as on a chain without couplings
  /// (the columns n .. stride - 1 stay 0: the staging is read in groups of 4).
  std::vector<int> slot;
  /// The workspace's shape: false, a small chain (kSmallJoints ...): stride = kSmallJoints and
  /// slot_count = kSmallSlots, the fixed arrays' sizes; true, a large one: stride =
  /// RoundUpTo4(n), slot_count = stride + the number of driven joints. The stride is the row
  /// stride of J and of the Cholesky factor, the columns' capacity.
  bool large = false;
  int stride = kSmallJoints;
  int slot_count = kSmallSlots;
  /// Joints 0 .. plain_joints - 1 all have slot k (the backward sweep writes their columns as
  /// on a chain without couplings, without reading `slot`).
  int plain_joints = 0;
  /// Coupled chains: the joints that own no column, in chain order, with their coordinate's
  /// column, their slot and their coupling (f; scan: a knot function's common case, evaluated
  /// inline; both point into `coupling`, which keeps them alive). The coupling step gives each
  /// its q_joint = f(q_column) and dq_joint; after the sweep its slot is folded into its column:
  /// column (= if `set`, else +=) dq_joint slot, `set` for the first fold into a column without
  /// owner. So J = J_joints C with C = dq_joint/dq, and dL/dq = C^T dL/dq_joint.
  struct DrivenJoint {
    int joint = 0, column = 0, slot = 0;
    bool set = false;
    const Function::Impl* f = nullptr;
    KnotScan scan;
  };
  std::vector<DrivenJoint> driven_joints;
  /// Coupled chains: the joint positions start as q_joint[k] = q[k] for k < n (copied four per
  /// vector); then q_joint[joint] = q[column] for these owners, whose column is not k, and the
  /// driven joints evaluate their couplings.
  struct MovedPosition {
    int joint = 0, column = 0;
  };
  std::vector<MovedPosition> moved_positions;
  /// The columns no joint drives (J and dL/dq are 0 there).
  std::vector<int> undriven_columns;
  /// False when every movable joint k carries column k with the identity (n == m): the kernel
  /// skips the coupling step. True: q_joint and dq_joint/dq come first, the sweep writes each
  /// joint's column at its slot, and the driven joints' slots are folded into their columns.
  bool coupled = false;
  std::vector<char> locked;  ///< per column: held rigid by the statics
  bool any_locked = false;
  std::vector<FastMuscle> muscles;
  /// The workspaces' sizes besides m, n and slot_count: the most path points of a muscle and
  /// the most moving components (FastMuscle::moving) of a muscle.
  int max_points = 0;
  int max_moving = 0;
  /// Movable joints of the description whose coupling is constant over their coordinate's
  /// range (ConstantCoupling), folded into the fixed transforms like fixed joints: not among
  /// `joints`. Their names, in chain order.
  std::vector<std::string> folded_joints;
  std::map<std::string, LinkFrame> links;
  /// Endpoint in the frame after the last movable joint (m), and the endpoint link's rotation
  /// in that frame (fixed joints after the last movable one).
  Eigen::Vector3d endpoint = Eigen::Vector3d::Zero();
  Eigen::Matrix3d endpoint_rotation = Eigen::Matrix3d::Identity();
  /// Transducer axes: R_W_T = rotation (axes_in_world) or R_last * rotation (turning with
  /// the distal bone; fixed joints after the last movable one folded in).
  bool transducer_in_world = true;
  Eigen::Matrix3d transducer_rotation = Eigen::Matrix3d::Identity();
  bool transducer_identity = true;  ///< in world and R_W_T = I: no rotation of J needed
};

struct Model::Impl {
  LimbDescription description;
  /// Per column (independent coordinate): its name, kind, and the JointSpec Model::joint()
  /// returns (the carrying joint, or one made from a free-standing coordinate).
  std::vector<std::string> joint_names;
  std::vector<bool> revolute;
  std::vector<JointSpec> columns;
  FlatChain flat;
  double chain_length = 0.0;
  StiffnessSet stiffness;  ///< Model::model_stiffness()
};

/// The value of a coupling that is constant over its coordinate's range, or false when it is
/// not: `coupling` restricted to [lower, upper] (the coordinate's range, rad or m) when both
/// are finite, else to all reals (an infinite end: the function must be constant to that side
/// too), takes one value. Constant: always; Linear (and a Multiplier of one): slope 0 (or a
/// Multiplier scale 0: any inner function); Polynomial: every coefficient but c_0 zero; a knot
/// function: every interval cubic that meets the range has b = c = d = 0 and, where the range
/// reaches past an end knot, that end's slope is 0 (OpenSim extrapolates linearly with it).
/// Model compile folds such joints into fixed transforms, and `isowrench import` writes them
/// as fixed joints (docs/model.md "Constant couplings").
bool ConstantCoupling(const Function& coupling, double lower, double upper, double* value);

/// Build the KDL chain for a validated description: the independent reference the tests and
/// the benchmark baseline compare the engine with (one KDL segment per description joint, fixed
/// ones as Joint::None, then one fixed "isowrench_endpoint" segment whose tip is the endpoint).
KDL::Chain BuildKdlChain(const LimbDescription& description);

}  // namespace isowrench
