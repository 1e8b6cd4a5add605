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
#include "model/function_impl.hpp"

namespace isowrench {
namespace {

using V = V4;
using VI = V4i;
constexpr std::int64_t kMagnitude = 0x7fffffffffffffff;  // all bits of a double but the sign

// Lane mask (all bits set where true, 0 where false) to a bitmask, bit l for lane l: lane l
// keeps bit l, and the lanes are or-ed together in the vector.
ISOWRENCH_INLINE unsigned Bits(const VI& mask) {
  const VI b = mask & VI{1, 2, 4, 8};
  const VI pairs = b | __builtin_shufflevector(b, b, 2, 3, 0, 1);
  return static_cast<unsigned>((pairs | __builtin_shufflevector(pairs, pairs, 1, 0, 3, 2))[0]);
}

// Value and slope of the knot function f at a[l] in each lane: KnotValueAndSlope with its
// branches as selects (the last applied wins: below, above, at an end knot, else interval k).
// Interval k (x[k] < a < x[k+1]) is found by counting the interior knots below a; a lane whose
// a equals an interior knot gets its bit in `on_knot` and must be evaluated by
// KnotValueAndSlope (there OpenSim's bisection decides between the two intervals).
ISOWRENCH_INLINE void KnotLanes(const Function::Impl& f, const V& a, V& value, V& slope,
                                VI& on_knot) {
  const double* x = f.x.data();
  const int n = static_cast<int>(f.x.size());
  VI count = VI{0, 0, 0, 0};
  VI equal = VI{0, 0, 0, 0};
  for (int i = 1; i + 1 < n; ++i) {
    const V xi = ISOWRENCH_V4_SPLAT(x[i]);
    count -= (VI)(xi < a);  // a true lane is -1
    equal |= (VI)(xi == a);
  }
  // Interval k of each lane: x_k, and y_k, b_k, c_k, d_k as one vector per lane, transposed.
  V xk, p[kLanes];
  ISOWRENCH_UNROLL
  for (int l = 0; l < kLanes; ++l) {
    const auto k = static_cast<size_t>(count[l]);
    xk[l] = x[k];
    std::memcpy(&p[l], f.ybcd.data() + 4 * k, sizeof p[l]);
  }
  const V t0 = __builtin_shufflevector(p[0], p[1], 0, 4, 2, 6);
  const V t1 = __builtin_shufflevector(p[0], p[1], 1, 5, 3, 7);
  const V t2 = __builtin_shufflevector(p[2], p[3], 0, 4, 2, 6);
  const V t3 = __builtin_shufflevector(p[2], p[3], 1, 5, 3, 7);
  const V yk = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  const V bk = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  const V ck = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  const V dk = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
  const V dx = a - xk;
  value = yk + dx * (bk + dx * (ck + dx * dk));
  slope = bk + dx * (2.0 * ck + 3.0 * dx * dk);
  on_knot = equal;
  // Lanes more than kKnotRoundoffError inside both end knots (where a >= x[0], |a - x[0]| is
  // a - x[0]; likewise at the last knot) keep their interval's cubic: when every lane is, the
  // selects below change nothing.
  const V x0 = ISOWRENCH_V4_SPLAT(x[0]), xn = ISOWRENCH_V4_SPLAT(x[n - 1]);
  const V roundoff = ISOWRENCH_V4_SPLAT(kKnotRoundoffError);
  if (Bits(((a - x0) > roundoff) & ((xn - a) > roundoff)) == (1u << kLanes) - 1) return;
  const double* first = f.ybcd.data();  // y, b, c, d of the end knots
  const double* last = first + 4 * (n - 1);
  const V y0 = ISOWRENCH_V4_SPLAT(first[0]), yn = ISOWRENCH_V4_SPLAT(last[0]);
  const V b0 = ISOWRENCH_V4_SPLAT(first[1]), bn = ISOWRENCH_V4_SPLAT(last[1]);
  const VI at_end = (V)((VI)(a - xn) & kMagnitude) <= roundoff;
  const VI at_start = (V)((VI)(a - x0) & kMagnitude) <= roundoff;
  const VI above = a > xn;
  const VI below = a < x0;
  V v = value, s = slope;
  v = at_end ? yn : v;
  s = at_end ? bn : s;
  v = at_start ? y0 : v;
  s = at_start ? b0 : s;
  v = above ? yn + (a - xn) * bn : v;
  s = above ? bn : s;
  v = below ? y0 + (a - x0) * b0 : v;
  s = below ? b0 : s;
  value = v;
  slope = s;
  on_knot = equal & ~(at_end | at_start | above | below);
}

}  // namespace

// The lane workspace (src/fast/kernel.hpp describes what the kernel needs).
struct LaneWorkspace::Impl {
  using Scalar = V;
  int m = 0;
  V q[kMaxDofs];         // joint positions q_joint = f(q_c) (= q_c without couplings)
  V qc[kMaxDofs];        // coupled chains: the postures' coordinates
  V dq_joint[kMaxDofs];  // and dq_joint/dq_c of the driven joints
  Vec3<V> origin[kMaxDofs];
  Vec3<V> axis[kMaxDofs];
  Vec3<V> points[kFastMaxPathPoints];
  Vec3<V> pulls[kFastMaxPathPoints];
  V J[6][kMaxSlots];  // row-major: column k is [v; w] in transducer axes (slots: FlatChain::slot)
  V tau[kMaxSlots];
  V length;
  V U[kMaxDofs * kMaxDofs];  // statics (kernel::Cholesky)
  V x[kMaxDofs];             // dtheta
  // The stiffness sets in the lanes (LaneSolve); `splatted`: the one set in every lane, if so.
  // Sets are not changed during a batch, so the same pointer means the same numbers.
  V s_t[6];
  V s_p[kMaxDofs];
  const StiffnessSet* splatted = nullptr;
  V* JacobianData() { return J[0]; }
  static int JacobianStride() { return kMaxSlots; }
  V* TauData() { return tau; }
  void Resize(int) {}
};

// The buffers are written before they are read (J too: zeroed here only so that no entry is
// ever uninitialised).
LaneWorkspace::LaneWorkspace(const Model& model) : impl_(new Impl) {
  impl_->m = model.dof_count();
  for (auto& row : impl_->J) {
    for (V& entry : row) entry = ISOWRENCH_V4_SPLAT(0.0);
  }
}

LaneWorkspace::~LaneWorkspace() = default;

ISOWRENCH_CLONES unsigned LaneKinematics(const Model& model, LaneWorkspace& workspace,
                                         const double* const q[kLanes], int muscle,
                                         double activation) {
  const FlatChain& d = model.impl().flat;
  LaneWorkspace::Impl& ws = workspace.impl();
  // The coordinates of the four postures, four per step by a 4 x 4 transpose, and whether each
  // is within the lane sin/cos range (every coordinate, not only the angles: a prismatic one
  // beyond 1e5 m only sends its lane to the scalar path too). Joint k takes coordinate k: on a
  // coupled chain the coordinates are also kept apart (ws.qc) for the joints that take another
  // one and for the couplings.
  VI out_of_range = VI{0, 0, 0, 0};
  auto coordinates = [&](auto coupled_tag) ISOWRENCH_LAMBDA_INLINE {
    auto put = [&](int c, const V& value) ISOWRENCH_LAMBDA_INLINE {
      ws.q[c] = value;
      if constexpr (decltype(coupled_tag)::value) ws.qc[c] = value;
      out_of_range |= (V)((VI)value & kMagnitude) >= sincos::kMaxReduced;
    };
    const int n = d.n;
    int c = 0;
    for (; c + 4 <= n; c += 4) {
      V a0, a1, a2, a3;  // al = q[l][c .. c + 3]
      std::memcpy(&a0, q[0] + c, sizeof a0);
      std::memcpy(&a1, q[1] + c, sizeof a1);
      std::memcpy(&a2, q[2] + c, sizeof a2);
      std::memcpy(&a3, q[3] + c, sizeof a3);
      const V t0 = __builtin_shufflevector(a0, a1, 0, 4, 2, 6);
      const V t1 = __builtin_shufflevector(a0, a1, 1, 5, 3, 7);
      const V t2 = __builtin_shufflevector(a2, a3, 0, 4, 2, 6);
      const V t3 = __builtin_shufflevector(a2, a3, 1, 5, 3, 7);
      put(c, __builtin_shufflevector(t0, t2, 0, 1, 4, 5));
      put(c + 1, __builtin_shufflevector(t1, t3, 0, 1, 4, 5));
      put(c + 2, __builtin_shufflevector(t0, t2, 2, 3, 6, 7));
      put(c + 3, __builtin_shufflevector(t1, t3, 2, 3, 6, 7));
    }
    for (; c < n; ++c) put(c, V{q[0][c], q[1][c], q[2][c], q[3][c]});
  };
  if (!d.coupled) {
    coordinates(std::false_type{});
  } else {
    coordinates(std::true_type{});
    for (const FlatChain::MovedPosition& p : d.moved_positions) ws.q[p.joint] = ws.qc[p.column];
    for (const FlatChain::DrivenJoint& c : d.driven_joints) {
      unsigned one_by_one = (1u << kLanes) - 1;
      if (IsKnotFunction(c.f->kind)) {
        VI on_knot;
        KnotLanes(*c.f, ws.qc[c.column], ws.q[c.joint], ws.dq_joint[c.joint], on_knot);
        one_by_one = Bits(on_knot);
      }
      for (int l = 0; one_by_one != 0 && l < kLanes; ++l) {
        if (!(one_by_one & (1u << l))) continue;
        double q_joint, dq_joint;
        d.coupling[c.joint].ValueAndDerivative(q[l][c.column], &q_joint, &dq_joint);
        ws.q[c.joint][l] = q_joint;
        ws.dq_joint[c.joint][l] = dq_joint;
      }
      // (not finite too: a coupling may overflow)
      out_of_range |= ((V)((VI)ws.q[c.joint] & kMagnitude) < sincos::kMaxReduced) == 0;
    }
  }
  const FastMuscle& mu = d.muscles[muscle];
  const double minus_force = -(activation * mu.max_force);
  VI coincident;
  // The general kernel on every chain (without couplings every joint has slot k and no fold;
  // one instantiation for both halves this file's compile time, for ~3 instructions).
  kernel::Kinematics<false, false, true>(d, ws, ws.q, mu, minus_force, !d.transducer_identity,
                                         coincident);
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
  kernel::Cholesky<N, false>(m, ws.J[0], static_cast<const V*>(nullptr), kMaxSlots, s_t, s_p,
                             ws.tau, tolerance, ws.U, ws.x, wrench, undecided);
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneSolve(const Model& model, LaneWorkspace& workspace,
                                    const StiffnessSet* const sets[kLanes],
                                    const SolveOptions& options, WrenchResult* const out[kLanes]) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const int m = ws.m;  // the model's dof count
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
