#pragma once
/// @file
/// The engine: forward kinematics, endpoint Jacobian in transducer axes, muscle torque, then the
/// compliant statics of docs/model.md "Statics"
///   K = J^T S_t J + S_p,   K dtheta = tau,   W = S_t J dtheta,
/// on the Model's compiled chain, with no allocation per evaluation, and a batch API that spreads
/// many postures and many stiffness sets over threads. It is the only engine: the kinematics
/// functions (kinematics.hpp) and EvaluateWrench (statics.hpp) run the same kernel.
///
/// Model/Data split (model.hpp): the Model is immutable and shared between threads; a Data is
/// the mutable scratch of one thread (sized once, reused), and holds the results of the last
/// evaluation. tests/core checks the kinematics against orocos KDL; tests/fast/ prove the solve
/// and the batch lanes equal to EvaluateWrench on random postures of every shipped URDF.
/// Columns are the Model's independent coordinates: coupled joints are folded (J = J_joints C),
/// and locked coordinates are rigid in the solve (dtheta = 0 there).
///
///   isowrench::Data data(model);
///   isowrench::WrenchResult w = isowrench::Evaluate(model, data, q, /*muscle=*/0,
///                                                   model.model_stiffness());
///   // w.wrench: [fx fy fz mx my mz] N and N·m, applied by the limb to the transducer,
///   // moment about the endpoint, in transducer axes; StatusMessage(w) says what happened.
///
/// Differences from the full report of EvaluateWrench, stated once: Evaluate returns no
/// eigenvalues and no small-motion check (use EvaluateWrench for a full report on one posture).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

/// Numerical decisions of the fast solve. Each states the inequality it controls.
struct SolveOptions {
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
struct WrenchResult {
  /// W = S_t J dtheta [f; m] (N, N·m), the wrench the limb applies to the transducer, moment
  /// about the endpoint origin, in transducer axes; zeros unless status is kOk or
  /// kSelfMotionHeld. Released rows are 0.
  Vector6d wrench = Vector6d::Zero();
  /// kOk: K positive definite. kSelfMotionHeld: K singular, tau does not excite the self-motion,
  /// W unique (pseudo-inverse solve). kSelfMotion: tau drives the self-motion, no W.
  /// kInvalidInput: negative/non-finite stiffness or tau, or a muscle path segment shorter than
  /// 1 nm at this posture.
  StaticsStatus status = StaticsStatus::kInvalidInput;
  /// Dimension of null(K) (0 when K is regular); the basis is Data::self_motion().
  int self_motion_count = 0;
};

/// What a WrenchResult's status means for this result, in a sentence (the message that
/// StaticsResult and ClassicResult carry, made on demand so that WrenchResult stays 64 bytes),
/// e.g. "self-motion: tau drives 1 direction of null(K); no equilibrium, W not defined".
std::string StatusMessage(const WrenchResult& result);

/// Forward kinematics, endpoint Jacobian (transducer axes) and the muscle torque of muscle
/// `muscle` at activation `activation` at posture q (model.dof_count() entries, rad / m):
/// tau = -F dL/dq with F = MuscleForceAt(model, muscle, L_MT, activation) (a * max_force for a
/// constant-force muscle). Results are left in `data` (jacobian(), tau(), ...). Returns false,
/// leaving tau zero, when two consecutive path points coincide (closer than 1 nm) at this
/// posture, or the muscle's force model has no equilibrium at its length
/// (MuscleForceStatus::kNoEquilibrium). No allocation. A muscle with a force model throws
/// Error for an activation outside [0, 1]. Preconditions (asserted, not checked in release
/// builds): q has dof_count() finite entries and 0 <= muscle < muscle_count().
bool ComputeKinematics(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q,
                       int muscle, double activation = 1.0);

/// The force stage: the tension F (N) of muscle `muscle` at musculotendon length `length` (m,
/// the path length L_MT) and activation `activation` (in [0, 1]) from the muscle's force model
/// (MuscleSpec::force, compiled once when the Model was built; docs/muscle.md). This is the one
/// F(L_MT, a) the engine multiplies the moment arms with (tau = -F dL/dq): ComputeKinematics,
/// Evaluate and EvaluateBatch for a muscle with a force model, and every report. The constant
/// model gives a * max_force at any length (the engine multiplies that into the kernel as it
/// always did). No allocation.
/// @throws Error for a muscle index out of range or an activation outside [0, 1] (naming the
///         muscle and the value).
MuscleForce MuscleForceAt(const Model& model, int muscle, double length, double activation);

/// The compiled force model of muscle `muscle` (curves, limits, opensim_limitation()), the one
/// MuscleForceAt evaluates. @throws Error for a muscle index out of range.
const MuscleForceModel& ForceModelOf(const Model& model, int muscle);

/// Statics on the Jacobian and torque held in `data` (from ComputeKinematics) with one set of
/// compliances. No allocation.
WrenchResult SolveStatics(const Model& model, Data& data, const StiffnessSet& stiffness,
                          const SolveOptions& options = {});

/// ComputeKinematics + SolveStatics: one evaluation of the kernel. No allocation.
/// @throws Error naming the muscle and the value for an activation outside [0, 1] or NaN (every
///         force model, the constant one too).
WrenchResult Evaluate(const Model& model, Data& data, const Eigen::Ref<const Eigen::VectorXd>& q,
                      int muscle, const StiffnessSet& stiffness, double activation = 1.0,
                      const SolveOptions& options = {});

/// Moves the path points of muscle `muscle` in every later evaluation of that muscle through
/// this Data, without rebuilding the Model (how uncertainty studies perturb attachments,
/// docs/uncertainty.md "Muscle points"): point i of MuscleSpec::path is taken at its position
/// plus offsets.col(i) (m, in the point's link frame). A wrapped muscle's wrap
/// surfaces stay where they are: only the path points move. One muscle at a time: a call
/// replaces any offsets set before. ComputeKinematics, Evaluate and the kinematics functions
/// (kinematics.hpp) that take this Data see the moved points; other muscles, other Datas and
/// EvaluateBatch (which makes its own workspaces) do not. The Data keeps a copy of the muscle
/// with its points moved, which the same kernel runs (no other cost per evaluation); a moving
/// point's offset adds to its position at every coordinate value, a conditional point's applies
/// while it is active. Allocates on the first call for a muscle only.
/// @throws Error for a Data made for another model, a muscle index out of range, offsets that
///         are not 3 x (the muscle's path points), or a non-finite offset.
void SetPathPointOffsets(const Model& model, Data& data, int muscle,
                         const Eigen::Ref<const Eigen::Matrix3Xd>& offsets);

/// Removes the offsets of SetPathPointOffsets: later evaluations use the model's points.
void ClearPathPointOffsets(Data& data);

/// The statics on raw matrices (J: 6 x m rows [v; w] in transducer axes, s_t N/m and N·m/rad,
/// s_p and tau with m entries), for lab tools with their own kinematics. m must equal the
/// workspace's dof count; bad sizes or values give kInvalidInput. No allocation.
WrenchResult SolveStatics(Data& data, const Eigen::Ref<const Matrix6Xd>& J, const Vector6d& s_t,
                          const Eigen::Ref<const Eigen::VectorXd>& s_p,
                          const Eigen::Ref<const Eigen::VectorXd>& tau,
                          const SolveOptions& options = {});

/// Options of EvaluateBatch.
struct BatchOptions {
  /// Worker threads (>= 1); each gets its own workspaces. 2 uses both cores of a 2-core
  /// machine. More threads than blocks of work are not started.
  int threads = 2;
  /// Called on the calling thread with (evaluations done, evaluations total), an evaluation
  /// being one posture with one stiffness set, after each unit of work it finishes and once at
  /// the end; may be empty.
  std::function<void(long, long)> progress;
  SolveOptions solve;
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
/// PathPoint::active_coordinate) or with wraps (MuscleSpec::wraps, computed by the scalar wrap
/// code, include/isowrench/wrap.hpp) has its kinematics on the scalar path, one posture at a
/// time, its statics still four sets at a time (docs/performance.md). An evaluation the lanes
/// cannot decide is redone by the scalar path: a Cholesky pivot at or below
/// SolveOptions::cholesky_pivot_tolerance (a singular or nearly singular K), a non-finite result,
/// coincident path points, or a revolute angle |q| >= 1e5 rad. So statuses, self-motion counts and
/// kSelfMotionHeld wrenches are those of Evaluate; kOk wrenches agree with Evaluate to rounding
/// (the lanes may fuse multiply-adds differently, which moves W by about eps cond(K)). Allocates
/// only the output and the workspaces of each thread.
/// @throws Error if postures has the wrong row count or a non-finite entry, the muscle index is
///         out of range, a stiffness set has the wrong size, `stiffness` is empty, or the
///         activation is outside [0, 1] or NaN (every force model; naming the muscle and value).
void EvaluateBatch(const Model& model, const Eigen::Ref<const Eigen::MatrixXd>& postures,
                   int muscle, const std::vector<StiffnessSet>& stiffness,
                   std::vector<WrenchResult>& out, double activation = 1.0,
                   const BatchOptions& options = {});

}  // namespace isowrench
