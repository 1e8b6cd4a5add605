#pragma once
// Private: the batch kernel, four evaluations at once, one per lane of a 4-double SIMD register
// (AVX2 on x86-64-v3; two SSE2 registers per lane group on older CPUs). The same kernel as
// ComputeKinematics + SolveStatics; a lane it cannot decide is flagged and the caller
// redoes it on the scalar path, which owns the eigen-solve and the self-motion report.

#include <cstddef>
#include <memory>

#include "isowrench/engine.hpp"

namespace isowrench {

/// Evaluations per lane group.
inline constexpr int kLanes = 4;

/// Scratch of the lane kernel for one thread: the lane kinematics (frames, J, tau) of up to four
/// postures. Constructed once; the functions below never allocate.
class LaneWorkspace {
 public:
  explicit LaneWorkspace(const Model& model);
  ~LaneWorkspace();
  LaneWorkspace(const LaneWorkspace&) = delete;
  LaneWorkspace& operator=(const LaneWorkspace&) = delete;

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Kinematics and muscle torque (muscle `muscle`, force = activation * max_force) of posture
/// q[l] (dof_count() entries each) in lane l. Returns the bitmask of lanes (bit l) the caller
/// must evaluate on the scalar path instead: two consecutive path points coincide (kInvalidInput
/// there), or a revolute angle has |q| >= 1e5 rad, beyond the lane sin/cos range reduction
/// (checked for every coordinate and every driven joint's position, which must also be finite:
/// a prismatic one beyond 1e5 m, which the lanes could compute, goes to the scalar path too).
/// force_stage false: a muscle with a force model keeps tau for a unit force (the caller scales
/// it by LaneApplyForce).
unsigned LaneKinematics(const Model& model, LaneWorkspace& ws, const double* const q[kLanes],
                        int muscle, double activation, bool force_stage = true);

/// The doubles one lane group's Jacobian and torque take in a store (LaneStore); 0 where the
/// workspace keeps them only in itself (a large chain).
std::size_t LaneGroupSize(const LaneWorkspace& ws);

/// Makes the lane functions write and read J and tau at `store` (LaneGroupSize doubles,
/// 32-byte aligned), or in the workspace itself (nullptr). Only where LaneGroupSize > 0.
void LaneStore(LaneWorkspace& ws, double* store);

/// The muscle's path length in each lane after LaneKinematics (m).
void LaneLengths(LaneWorkspace& ws, double length[kLanes]);

/// The force stage after LaneKinematics(..., false): tau scaled by force[l] (lanes in `skip`
/// get 0). Returns the lanes with status kNoEquilibrium, not in skip (for the scalar path).
unsigned LaneApplyForce(LaneWorkspace& ws, const double force[kLanes],
                        const MuscleForceStatus status[kLanes], unsigned skip);

/// Puts the Jacobian and torque of the scalar workspace (after ComputeKinematics) in every
/// lane: one posture, a different stiffness set per lane.
void LaneBroadcast(const Data& scalar, LaneWorkspace& ws);

/// The statics of lane l with stiffness set *sets[l] (each checked by the caller: sizes match,
/// entries finite and >= 0), writing *out[l] with status kOk. Returns the bitmask of lanes left
/// undecided (a Cholesky pivot at or below SolveOptions::cholesky_pivot_tolerance, or a
/// non-finite result); their *out[l] is not written and the caller solves them on the scalar
/// path. When every lane has the same set, the workspace keeps it splatted and reuses it while
/// the next calls pass the same pointer: a set must not change while a workspace uses it (one
/// EvaluateBatch call).
unsigned LaneSolve(const Model& model, LaneWorkspace& ws, const StiffnessSet* const sets[kLanes],
                   const SolveOptions& options, WrenchResult* const out[kLanes]);

}  // namespace isowrench
