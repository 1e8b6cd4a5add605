#pragma once
/// @file
/// The fast path: the same kernel as EvaluateWrench (forward kinematics, endpoint Jacobian in
/// transducer axes, muscle torque, then the compliant statics of docs/model.md "Statics")
///   K = J^T S_t J + S_p,   K dtheta = tau,   W = S_t J dtheta,
/// on a flat, compiled copy of the Model's chain, with no allocation per evaluation, and a
/// batch API that spreads many postures and many stiffness sets over threads.
///
/// Model/Data split: CompiledModel is immutable and shared; FastWorkspace is the mutable scratch
/// of one thread (sized once, reused). The kinematics kernel is the one the Model's kinematics
/// functions and EvaluateWrench run (tests/core checks it against orocos KDL); tests/fast/
/// prove the fast solve and the batch lanes equal to EvaluateWrench on random postures of every
/// shipped URDF. Columns are the Model's independent coordinates: coupled joints are folded
/// (J = J_joints C), and locked coordinates are rigid in the solve (dtheta = 0 there).
///
///   isowrench::CompiledModel compiled(model);
///   isowrench::FastWorkspace ws(compiled);
///   isowrench::FastWrench w = isowrench::EvaluateFast(compiled, ws, q, /*muscle=*/0,
///                                                     compiled.model_stiffness());
///   // w.wrench: [fx fy fz mx my mz] N and N·m, applied by the limb to the transducer,
///   // moment about the endpoint, in transducer axes.
///
/// Differences from SolveStatics, stated once: the fast path returns no message, no
/// eigenvalues and no small-motion check (use EvaluateWrench for a full report on one posture).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

/// Largest number of movable joints the fast path handles (workspace matrices are fixed-size
/// buffers of this many rows/columns, so an evaluation never allocates).
inline constexpr int kFastMaxDofs = 16;

/// A joint-space vector of at most kFastMaxDofs entries, stored inline (no heap).
using FastJointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kFastMaxDofs, 1>;
/// An m x r matrix with m, r <= kFastMaxDofs, stored inline (no heap).
using FastJointMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kFastMaxDofs, kFastMaxDofs>;
/// A 6 x m endpoint Jacobian with m <= kFastMaxDofs, stored inline (no heap).
using FastJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kFastMaxDofs>;

/// One set of compliances for the statics.
struct StiffnessSet {
  /// S_t diagonal in transducer axes [kx ky kz krx kry krz] (N/m, N·m/rad), each >= 0; a zero
  /// entry is a released dof (docs/model.md "Released dofs").
  Vector6d s_t = Vector6d::Zero();
  /// S_p diagonal, one entry per movable joint in column order (N·m/rad or N/m), each >= 0.
  FastJointVector s_p;
};

/// Numerical decisions of the fast solve. Each states the inequality it controls.
struct FastOptions {
  /// Cholesky fast path: K is factored by Cholesky and accepted when every pivot d_k (the
  /// squared diagonal of L) satisfies d_k > cholesky_pivot_tolerance * max_i K_ii; otherwise
  /// the symmetric eigen-solve below decides the rank.
  double cholesky_pivot_tolerance = 1e-9;
  /// Eigen-solve: eigenvalue lambda_i of K counts as zero (a self-motion) when
  /// lambda_i <= rank_tolerance * lambda_max (as StaticsOptions::rank_tolerance).
  double rank_tolerance = 1e-12;
  /// A self-motion direction n (unit) is excited when |n . tau| > excitation_tolerance * |tau|
  /// (as StaticsOptions::excitation_tolerance).
  double excitation_tolerance = 1e-9;
};

/// Result of one fast evaluation: 64 bytes, no heap.
struct FastWrench {
  /// W = S_t J dtheta [f; m] (N, N·m), the wrench the limb applies to the transducer, moment
  /// about the endpoint origin, in transducer axes; zeros unless status is kOk or
  /// kSelfMotionHeld. Released rows are 0.
  Vector6d wrench = Vector6d::Zero();
  /// kOk: K positive definite. kSelfMotionHeld: K singular, tau does not excite the self-motion,
  /// W unique (pseudo-inverse solve). kSelfMotion: tau drives the self-motion, no W.
  /// kInvalidInput: negative/non-finite stiffness or tau, or a muscle path segment shorter than
  /// 1 nm at this posture.
  StaticsStatus status = StaticsStatus::kInvalidInput;
  /// Dimension of null(K) (0 when K is regular); the basis is FastWorkspace::self_motion().
  int self_motion_count = 0;
};

/// The Model's chain compiled to flat arrays: per movable joint its fixed transform from the
/// previous movable joint's frame (fixed joints folded in), axis and type; per muscle path point
/// its movable-joint frame and offset; the endpoint and transducer axes. Immutable, cheap to
/// copy (shared state), thread-safe to share.
class CompiledModel {
 public:
  /// Compile `model`. @throws Error if the model has more than kFastMaxDofs movable joints.
  explicit CompiledModel(const Model& model);

  /// Number of movable joints m.
  int dof_count() const;
  /// Number of muscles (same order as Model::muscle()).
  int muscle_count() const;
  /// True for revolute columns, false for prismatic ones.
  bool revolute(int column) const;
  /// The model's own compliances: S_t from the transducer spec with released dofs set to 0,
  /// S_p from the joint stiffnesses.
  StiffnessSet model_stiffness() const;
  /// The model this was compiled from.
  const Model& model() const;

  struct Data;
  const Data& data() const { return *data_; }

 private:
  std::shared_ptr<const Data> data_;
};

/// Mutable scratch of the fast path for one thread: the last evaluation's Jacobian, torque,
/// displacement and self-motion basis stay readable until the next evaluation.
/// Construction allocates once; evaluations never allocate.
class FastWorkspace {
 public:
  /// Workspace sized for `model`.
  explicit FastWorkspace(const CompiledModel& model);
  /// Workspace for the raw-matrix solve SolveStaticsFast with `dof_count` joints.
  /// @throws Error if dof_count is not in [1, kFastMaxDofs].
  explicit FastWorkspace(int dof_count);
  ~FastWorkspace();
  FastWorkspace(FastWorkspace&&) noexcept;
  FastWorkspace& operator=(FastWorkspace&&) noexcept;

  /// J_T_E (6 x m) of the last ComputeFastKinematics: rows [v; w] in transducer axes,
  /// reference point the endpoint origin (m/rad, m/m, rad/rad).
  const FastJacobian& jacobian() const;
  /// Muscle torque tau = -F (dL/dtheta)^T of the last kinematics (N·m or N per joint).
  const FastJointVector& tau() const;
  /// dL/dtheta of the last kinematics (m/rad or m/m per joint).
  const FastJointVector& muscle_length_gradient() const;
  /// Muscle length (m) of the last kinematics.
  double muscle_length() const;
  /// Endpoint position in world (m) of the last kinematics.
  const Eigen::Vector3d& endpoint_position() const;
  /// R_W_T of the last kinematics: transducer axes in world.
  const Eigen::Matrix3d& transducer_rotation() const;
  /// dtheta of the last solve (rad or m per joint); zeros after kSelfMotion / kInvalidInput.
  const FastJointVector& dtheta() const;
  /// Self-motion basis of the last solve: m x r, unit columns spanning null(K), largest entry
  /// positive (the same convention as StaticsResult::self_motion); r = 0 when K is regular.
  const FastJointMatrix& self_motion() const;

  struct Impl;
  Impl& impl() { return *impl_; }
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Forward kinematics, endpoint Jacobian (transducer axes) and the muscle torque of muscle
/// `muscle` at activation `activation` (force = activation * max_force) at posture q
/// (model.dof_count() entries, rad / m). Results are left in `ws` (jacobian(), tau(), ...).
/// Returns false, leaving tau zero, when two consecutive path points coincide (closer than
/// 1 nm) at this posture. No allocation. Preconditions (asserted, not checked in release
/// builds): q has dof_count() finite entries and 0 <= muscle < muscle_count().
bool ComputeFastKinematics(const CompiledModel& model, FastWorkspace& ws,
                           const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                           double activation = 1.0);

/// Statics on the Jacobian and torque held in `ws` (from ComputeFastKinematics) with one set of
/// compliances. No allocation.
FastWrench SolveFastStatics(const CompiledModel& model, FastWorkspace& ws,
                            const StiffnessSet& stiffness, const FastOptions& options = {});

/// ComputeFastKinematics + SolveFastStatics: one evaluation of the kernel. No allocation.
FastWrench EvaluateFast(const CompiledModel& model, FastWorkspace& ws,
                        const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                        const StiffnessSet& stiffness, double activation = 1.0,
                        const FastOptions& options = {});

/// The statics on raw matrices (J: 6 x m rows [v; w] in transducer axes, s_t N/m and N·m/rad,
/// s_p and tau with m entries), for lab tools with their own kinematics. m must equal the
/// workspace's dof count; bad sizes or values give kInvalidInput. No allocation.
FastWrench SolveStaticsFast(FastWorkspace& ws, const Eigen::Ref<const Matrix6Xd>& J,
                            const Vector6d& s_t, const Eigen::Ref<const Eigen::VectorXd>& s_p,
                            const Eigen::Ref<const Eigen::VectorXd>& tau,
                            const FastOptions& options = {});

/// Options of EvaluateBatch.
struct BatchOptions {
  /// Worker threads (>= 1); each gets its own workspaces. 2 uses both cores of a 2-core
  /// machine. More threads than blocks of work are not started.
  int threads = 2;
  /// Called on the calling thread with (evaluations done, evaluations total), an evaluation
  /// being one posture with one stiffness set, after each unit of work it finishes and once at
  /// the end; may be empty.
  std::function<void(long, long)> progress;
  FastOptions solve;
};

/// Evaluate muscle `muscle` at activation `activation` at every posture (one per column of
/// `postures`, m x P, rad / m) with every stiffness set (S sets): P * S results in
/// `out` (resized; index p * S + s).
///
/// How: the work is cut into blocks of postures x stiffness sets spread over the threads (sets
/// are split too when there are few postures, so one posture with many sets uses every
/// thread). Inside a block, four evaluations run at once, one per lane of a 4-double SIMD
/// register (AVX2 where the CPU has it): four postures share a stiffness set, or, for a
/// posture left over, four sets share its kinematics. Kinematics are computed once per
/// posture. A muscle with moving or conditional path points (PathPoint::moving,
/// PathPoint::active_coordinate) has its kinematics on the scalar path, one posture at a time,
/// its statics still four sets at a time. An evaluation the lanes cannot decide is redone by the
/// scalar path: a Cholesky pivot at or below FastOptions::cholesky_pivot_tolerance (a singular or
/// nearly singular K), a non-finite result, coincident path points, or a revolute angle |q| >= 1e5
/// rad. So statuses, self-motion counts and kSelfMotionHeld wrenches are those of EvaluateFast; kOk
/// wrenches agree with EvaluateFast to rounding (the lanes may fuse multiply-adds
/// differently, which moves W by about eps cond(K)). Allocates only the output and the
/// workspaces of each thread.
/// @throws Error if postures has the wrong row count or a non-finite entry, the muscle index is
///         out of range, a stiffness set has the wrong size, or `stiffness` is empty.
void EvaluateBatch(const CompiledModel& model, const Eigen::Ref<const Eigen::MatrixXd>& postures,
                   int muscle, const std::vector<StiffnessSet>& stiffness,
                   std::vector<FastWrench>& out, double activation = 1.0,
                   const BatchOptions& options = {});

}  // namespace isowrench
