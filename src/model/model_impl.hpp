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

namespace isowrench {

/// Most path points per muscle (the workspaces hold this many).
inline constexpr int kFastMaxPathPoints = 64;

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

struct FastMuscle {
  double max_force = 0.0;
  std::vector<FastPathPoint> points;  ///< path order
  std::vector<int> ground_points;     ///< the points on ground (frame -1)
  /// Point indices ordered by decreasing frame (ground points left out): the order of the
  /// backward torque sweep.
  std::vector<int> sweep_order;
  /// sweep_end[k]: how many entries of sweep_order have frame >= k (k = 0 .. m; sweep_end[m] =
  /// 0): the points of frame k are sweep_order[sweep_end[k + 1] .. sweep_end[k]).
  std::vector<int> sweep_end;
  /// The frames that have points, ascending, between the sentinels -1 and m: the joint loops
  /// compare the joint with the next such frame instead of reading sweep_end at every joint.
  std::vector<int> point_frames;
  /// Moving components of its points; `dynamic`: some point moves or is conditional, and each
  /// evaluation first runs PreparePathPoints (src/fast/path_points.cpp).
  std::vector<FastMovingComponent> moving;
  bool dynamic = false;
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
  int m = 0;  ///< movable joints
  int n = 0;  ///< independent coordinates: the public columns (J, tau, S_p, postures)
  std::vector<FastJoint> joints;
  /// One posture computes sin and cos of joints trig_begin .. trig_end - 1, four at a time: the
  /// revolute joints, widened towards the start to whole groups of 4 where possible (empty
  /// when no joint is revolute).
  int trig_begin = 0;
  int trig_end = 0;
  std::uint32_t revolute_mask = 0;  ///< bit k: movable joint k is revolute
  /// Per movable joint: the column of its coordinate and q_joint = coupling(q_column).
  std::vector<int> coordinate;
  std::vector<Function> coupling;
  std::vector<int> coupled_joints;  ///< the joints whose coupling is not the identity
  /// Per movable joint: no later joint drives its column (the backward sweep sets the column
  /// there instead of adding to it); and the columns no joint drives (J and dL/dq are 0 there).
  std::vector<char> first_in_column;
  std::vector<int> undriven_columns;
  /// False when every movable joint k carries column k with the identity (n == m): the kernel
  /// skips the coupling step. True: q_joint and dq_joint/dq come first, and the joint columns
  /// of J and dL/dq are folded into coordinate columns, J = J_joints C, C = dq_joint/dq.
  bool coupled = false;
  std::vector<char> locked;  ///< per column: held rigid by the statics
  bool any_locked = false;
  std::vector<FastMuscle> muscles;
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

/// Build the KDL chain for a validated description: the independent reference the tests and
/// the benchmark baseline compare the engine with (one KDL segment per description joint, fixed
/// ones as Joint::None, then one fixed "isowrench_endpoint" segment whose tip is the endpoint).
KDL::Chain BuildKdlChain(const LimbDescription& description);

}  // namespace isowrench
