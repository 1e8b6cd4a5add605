// The batch kernel: the engine of fast/kernel.hpp instantiated on 4-double vectors (GCC vector
// extensions), one evaluation per lane; only the marshalling of postures and stiffness sets
// into lanes and of results out of them is here. tests/fast/ prove the lanes equal to the
// scalar path to rounding, including padded and undecided lanes.

#include "fast/lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "fast/fast_impl.hpp"
#include "fast/kernel.hpp"
#include "fast/simd.hpp"

namespace isowrench {
namespace {

using V = V4;
using VI = V4i;

// Lane mask (all bits set where true) to a bitmask, bit l for lane l.
ISOWRENCH_INLINE unsigned Bits(const VI& mask) {
  unsigned bits = 0;
  for (int l = 0; l < kLanes; ++l) bits |= mask[l] != 0 ? 1u << l : 0u;
  return bits;
}

}  // namespace

// The lane workspace (src/fast/kernel.hpp describes what the kernel needs).
struct LaneWorkspace::Impl {
  using Scalar = V;
  int m = 0;
  V q[kMaxDofs];  // joint positions
  V q_joint[kMaxDofs];
  V dq_joint[kMaxDofs];
  V origin[kMaxDofs][3];
  V axis[kMaxDofs][3];
  V points[kFastMaxPathPoints][3];
  V pulls[kFastMaxPathPoints][3];
  V J[6][kMaxDofs];  // row-major: column k is [v; w] in transducer axes
  V dL[kMaxDofs];
  V tau[kMaxDofs];
  V length;
  V U[kMaxDofs * kMaxDofs];  // statics (kernel::Cholesky)
  V x[kMaxDofs];             // dtheta
  // The stiffness sets in the lanes (LaneSolve); `splatted`: the one set in every lane, if so.
  // Sets are not changed during a batch, so the same pointer means the same numbers.
  V s_t[6];
  V s_p[kMaxDofs];
  const StiffnessSet* splatted = nullptr;
  V* JacobianData() { return J[0]; }
  static int JacobianStride() { return kMaxDofs; }
  V* DlData() { return dL; }
  V* TauData() { return tau; }
  void Resize(int) {}
};

// The buffers are written before they are read.
LaneWorkspace::LaneWorkspace(const Model& model) : impl_(new Impl) { impl_->m = model.dof_count(); }

LaneWorkspace::~LaneWorkspace() = default;

ISOWRENCH_CLONES unsigned LaneKinematics(const Model& model, LaneWorkspace& workspace,
                                         const double* const q[kLanes], int muscle,
                                         double activation) {
  const FlatChain& d = model.impl().flat;
  LaneWorkspace::Impl& ws = workspace.impl();
  // Joint positions (on a coupled chain q_joint = f(q_c), lane by lane, with the derivatives
  // for the kernel's fold), and whether every revolute angle is within the lane sin/cos range.
  VI out_of_range = VI{0, 0, 0, 0};
  for (int k = 0; k < d.m; ++k) {
    if (d.coupled && d.identity[k]) {  // a joint that is its own coordinate
      const int c = d.coordinate[k];
      ws.q[k] = V{q[0][c], q[1][c], q[2][c], q[3][c]};
      ws.dq_joint[k] = ISOWRENCH_V4_SPLAT(1.0);
    } else if (d.coupled) {
      const int c = d.coordinate[k];
      for (int l = 0; l < kLanes; ++l) {
        double q_joint, dq_joint;
        kernel::CoupleJoint(d, k, q[l][c], q_joint, dq_joint);
        ws.q[k][l] = q_joint;
        ws.dq_joint[k][l] = dq_joint;
      }
    } else {
      ws.q[k] = V{q[0][k], q[1][k], q[2][k], q[3][k]};
    }
    if (d.joints[k].revolute) {
      const V magnitude = (V)((VI)ws.q[k] & 0x7fffffffffffffff);
      out_of_range |= (magnitude < sincos::kMaxReduced) == 0;
    }
  }
  const FastMuscle& mu = d.muscles[muscle];
  VI coincident;
  kernel::Kinematics<false, false>(d, ws, ws.q, mu, -(activation * mu.max_force),
                                   !d.transducer_identity, coincident);
  return Bits(coincident | out_of_range);
}

ISOWRENCH_CLONES void LaneBroadcast(const Data& scalar, LaneWorkspace& workspace) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const Data::Impl& s = scalar.impl();
  for (int k = 0; k < ws.m; ++k) {
    for (int r = 0; r < 6; ++r) ws.J[r][k] = ISOWRENCH_V4_SPLAT(s.Jr[r * kMaxDofs + k]);
    ws.tau[k] = ISOWRENCH_V4_SPLAT(s.tau[k]);
  }
}

namespace {

// The kernel's statics on the lanes (N > 0: m fixed at compile time).
template <int N>
ISOWRENCH_INLINE void LaneCholesky(LaneWorkspace::Impl& ws, int m, const V* s_t, const V* s_p,
                                   double tolerance, V* wrench, VI& undecided) {
  kernel::Cholesky<N, false>(m, ws.J[0], static_cast<const V*>(nullptr), kMaxDofs, s_t, s_p, ws.tau,
                             tolerance, ws.U, ws.x, wrench, undecided);
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneSolve(const Model& model, LaneWorkspace& workspace,
                                    const StiffnessSet* const sets[kLanes],
                                    const SolveOptions& options, WrenchResult* const out[kLanes]) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const int m = model.dof_count();
  // Locked coordinates: the scalar path's SolveLocked decides every lane.
  if (model.impl().flat.any_locked) return (1u << kLanes) - 1;
  V* s_t = ws.s_t;
  V* s_p = ws.s_p;
  if (sets[0] == sets[1] && sets[0] == sets[2] && sets[0] == sets[3]) {  // four postures, one set
    if (ws.splatted != sets[0]) {  // the same set as the last call: already in the lanes
      for (int r = 0; r < 6; ++r) s_t[r] = ISOWRENCH_V4_SPLAT(sets[0]->s_t[r]);
      for (int i = 0; i < m; ++i) s_p[i] = ISOWRENCH_V4_SPLAT(sets[0]->s_p[i]);
      ws.splatted = sets[0];
    }
  } else {
    for (int r = 0; r < 6; ++r)
      s_t[r] = V{sets[0]->s_t[r], sets[1]->s_t[r], sets[2]->s_t[r], sets[3]->s_t[r]};
    for (int i = 0; i < m; ++i)
      s_p[i] = V{sets[0]->s_p[i], sets[1]->s_p[i], sets[2]->s_p[i], sets[3]->s_p[i]};
    ws.splatted = nullptr;
  }
  V wrench[6];
  const double tolerance = options.cholesky_pivot_tolerance;
  VI undecided;
  switch (m) {
    case 1: LaneCholesky<1>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 2: LaneCholesky<2>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 3: LaneCholesky<3>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 4: LaneCholesky<4>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 5: LaneCholesky<5>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 6: LaneCholesky<6>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 7: LaneCholesky<7>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    case 8: LaneCholesky<8>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
    default: LaneCholesky<0>(ws, m, s_t, s_p, tolerance, wrench, undecided); break;
  }
  const unsigned bits = Bits(undecided);
  for (int l = 0; l < kLanes; ++l) {
    if (bits & (1u << l)) continue;
    WrenchResult& w = *out[l];
    for (int r = 0; r < 6; ++r) w.wrench[r] = wrench[r][l];
    w.status = StaticsStatus::kOk;
    w.self_motion_count = 0;
  }
  return bits;
}

}  // namespace isowrench
