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

// The lane workspace (src/fast/kernel.hpp describes what the kernel needs), in the two shapes of
// the scalar one (fast_impl.hpp): a small chain's fixed-size arrays, a large chain's buffers
// sized from it in one allocation. The lane functions never allocate.
struct LaneWorkspace::Impl {
  explicit Impl(const FlatChain& d) : m(d.n), large(d.large) {}
  virtual ~Impl() = default;
  int m = 0;           // the columns (the model's coordinates)
  bool large = false;  // LargeLanes, else SmallLanes
  // The stiffness sets in the lanes (LaneSolve); `splatted`: the one set in every lane, if so.
  // Sets are not changed during a batch, so the same pointer means the same numbers.
  V s_t[6];
  const StiffnessSet* splatted = nullptr;
  V length;
};

namespace {

struct SmallLanes final : LaneWorkspace::Impl {
  using Scalar = V;
  static constexpr bool kLarge = false;
  static constexpr int kUStride = kSmallJoints;  // U's row stride
  explicit SmallLanes(const FlatChain& d) : Impl(d) {
    for (auto& row : J) {
      for (V& entry : row) entry = ISOWRENCH_V4_SPLAT(0.0);
    }
  }
  V q[kSmallJoints];         // joint positions q_joint = f(q_c) (= q_c without couplings)
  V qc[kSmallJoints];        // coupled chains: the postures' coordinates
  V dq_joint[kSmallJoints];  // and dq_joint/dq_c of the driven joints
  Vec3<V> origin[kSmallJoints];
  Vec3<V> axis[kSmallJoints];
  Vec3<V> points[kSmallPoints];
  Vec3<V> pulls[kSmallPoints];
  V J[6][kSmallSlots];  // row-major: column k is [v; w] in transducer axes (FlatChain::slot)
  V tau[kSmallSlots];
  V U[kSmallJoints * kSmallJoints];  // statics (kernel::Cholesky)
  V x[kSmallJoints];                 // dtheta
  V s_p[kSmallJoints];
  // Where the lane functions write and read J and tau: the arrays above, or a group's place in
  // the batch's store (LaneStore).
  V* jacobian = J[0];
  V* torque = tau;
  V* JacobianData() { return jacobian; }
  static int JacobianStride() { return kSmallSlots; }
  V* TauData() { return torque; }
  void Resize(int) {}
};

struct LargeLanes final : LaneWorkspace::Impl {
  using Scalar = V;
  static constexpr bool kLarge = true;
  explicit LargeLanes(const FlatChain& d)
      : Impl(d), kUStride(d.n), joints(d.m), slots(d.slot_count), points_count(d.max_points) {
    Lay(arena);
    arena.Allocate();
    Lay(arena);
  }
  void Lay(WorkspaceArena& a) {
    const auto columns = static_cast<std::size_t>(m);
    const auto slot_count = static_cast<std::size_t>(slots);
    a.Take(q, static_cast<std::size_t>(std::max(joints, m)));
    a.Take(qc, columns);
    a.Take(dq_joint, static_cast<std::size_t>(joints));
    a.Take(origin, static_cast<std::size_t>(joints));
    a.Take(axis, static_cast<std::size_t>(joints));
    a.Take(points, static_cast<std::size_t>(points_count));
    a.Take(pulls, static_cast<std::size_t>(points_count));
    a.Take(J, 6 * slot_count + 3);  // (+3: the large Cholesky's last blocks read past row 5)
    a.Take(tau, slot_count);
    a.Take(U, columns * columns);
    a.Take(x, columns);
    a.Take(s_p, columns);
    a.Take(inv_diag_scratch, columns);
    a.Take(y_scratch, columns);
  }
  WorkspaceArena arena;
  int kUStride;
  int joints, slots, points_count;
  Buffer<V> q, qc, dq_joint;
  Buffer<Vec3<V>> origin, axis, points, pulls;
  Buffer<V> J;  // row-major, row stride `slots`
  Buffer<V> tau, U, x, s_p;
  Buffer<V> inv_diag_scratch, y_scratch;  // the Cholesky's (kernel::CholeskyScratch)
  V* JacobianData() { return J.data(); }
  int JacobianStride() const { return slots; }
  V* TauData() { return tau.data(); }
  void Resize(int) {}
};

// Runs f on the lane workspace as its shape.
template <class F>
ISOWRENCH_INLINE auto WithLaneShape(bool large, LaneWorkspace::Impl& ws, F&& f) {
  return large ? f(static_cast<LargeLanes&>(ws)) : f(static_cast<SmallLanes&>(ws));
}

}  // namespace

LaneWorkspace::LaneWorkspace(const Model& model) {
  const FlatChain& d = model.impl().flat;
  if (d.large) {
    impl_ = std::make_unique<LargeLanes>(d);
  } else {
    impl_ = std::make_unique<SmallLanes>(d);
  }
}

LaneWorkspace::~LaneWorkspace() = default;

namespace {

// The force stage of the lanes: F(L_MT, a) of the four lanes' lengths by the force model's
// four-lane evaluation (MuscleTensionsOf: MuscleTensionOf's force and status per lane, bit for
// bit; vectorised where the lanes take the common path), tau scaled by it. Lanes already going
// to the scalar path (`skip`) get F = 0; a lane whose force model has no equilibrium goes there
// too (returned bit), which reports it.
// tau scaled by the lanes' forces (lanes `skip` get F = 0); returns the lanes whose status is
// kNoEquilibrium, not in skip.
ISOWRENCH_INLINE unsigned LaneScaleTau(V* tau, int m, const double force[kLanes],
                                       const MuscleForceStatus status[kLanes], unsigned skip) {
  V f;
  std::memcpy(&f, force, sizeof f);
  if (skip != 0) f = (V)((VI)f & (VI)((VI{1, 2, 4, 8} & static_cast<std::int64_t>(skip)) == 0));
  unsigned scalar = 0;
#if defined(__SSE2__)
  typedef int Ints4 __attribute__((vector_size(16)));
  typedef float Floats4 __attribute__((vector_size(16)));
  static_assert(kLanes * sizeof(MuscleForceStatus) == sizeof(Ints4), "MuscleForceStatus is an int");
  Ints4 s;
  std::memcpy(&s, status, sizeof s);
  scalar = static_cast<unsigned>(
      __builtin_ia32_movmskps((Floats4)(s == static_cast<int>(MuscleForceStatus::kNoEquilibrium))));
#else
  for (int l = 0; l < kLanes; ++l) {
    scalar |= static_cast<unsigned>(status[l] == MuscleForceStatus::kNoEquilibrium) << l;
  }
#endif
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC unroll 4
#endif
  for (int c = 0; c < m; ++c) tau[c] *= f;
  return scalar & ~skip;
}

template <class W>
ISOWRENCH_INLINE unsigned LaneForceStage(const FastMuscle& mu, W& ws, double activation,
                                         unsigned skip) {
  double force[kLanes];
  MuscleForceStatus status[kLanes];
  // (the lengths in place: Tension4, out of line, reads them with memcpy)
  MuscleTensionsOf(mu, reinterpret_cast<const double*>(&ws.length), activation, force, status);
  return LaneScaleTau(ws.TauData(), ws.m, force, status, skip);
}

template <class W>
ISOWRENCH_INLINE unsigned LaneKinematicsOf(const FlatChain& d, W& ws, const double* const q[kLanes],
                                           int muscle, double activation, bool force_stage) {
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
  // The force stage as on the scalar path (fast.cpp Kinematics): a unit force in the kernel for
  // a muscle with a force model, then tau scaled per lane by F(L_MT, a).
  const double minus_force = mu.force_curve ? -1.0 : -(activation * mu.max_force);
  VI coincident;
  // The general kernel on every chain (without couplings every joint has slot k and no fold;
  // one instantiation for both halves this file's compile time, for ~3 instructions).
  kernel::Kinematics<false, false, true>(d, ws, &ws.q[0], mu, minus_force, !d.transducer_identity,
                                         coincident);
  unsigned scalar = Bits(coincident | out_of_range);
  if (mu.force_curve && force_stage) scalar |= LaneForceStage(mu, ws, activation, scalar);
  return scalar;
}

// A large chain's, out of line.
ISOWRENCH_CLONES ISOWRENCH_NOINLINE unsigned LargeLaneKinematics(const FlatChain& d, LargeLanes& ws,
                                                                 const double* const q[kLanes],
                                                                 int muscle, double activation,
                                                                 bool force_stage) {
  return LaneKinematicsOf(d, ws, q, muscle, activation, force_stage);
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneKinematics(const Model& model, LaneWorkspace& workspace,
                                         const double* const q[kLanes], int muscle,
                                         double activation, bool force_stage) {
  const FlatChain& d = model.impl().flat;
  if (d.large) {
    return LargeLaneKinematics(d, static_cast<LargeLanes&>(workspace.impl()), q, muscle, activation,
                               force_stage);
  }
  return LaneKinematicsOf(d, static_cast<SmallLanes&>(workspace.impl()), q, muscle, activation,
                          force_stage);
}

std::size_t LaneGroupSize(const LaneWorkspace& workspace) {
  if (const_cast<LaneWorkspace&>(workspace).impl().large) return 0;
  return 7 * kSmallSlots * kLanes;  // J (6 rows of kSmallSlots) and tau, 4 doubles each
}

void LaneStore(LaneWorkspace& workspace, double* store) {
  SmallLanes& ws = static_cast<SmallLanes&>(workspace.impl());
  if (store == nullptr) {
    ws.jacobian = ws.J[0];
    ws.torque = ws.tau;
  } else {
    ws.jacobian = reinterpret_cast<V*>(store);
    ws.torque = ws.jacobian + 6 * kSmallSlots;
  }
}

void LaneLengths(LaneWorkspace& workspace, double length[kLanes]) {
  std::memcpy(length, &workspace.impl().length, sizeof(V));
}

ISOWRENCH_CLONES unsigned LaneApplyForce(LaneWorkspace& workspace, const double force[kLanes],
                                         const MuscleForceStatus status[kLanes], unsigned skip) {
  LaneWorkspace::Impl& ws = workspace.impl();
  V* tau =
      ws.large ? static_cast<LargeLanes&>(ws).TauData() : static_cast<SmallLanes&>(ws).TauData();
  return LaneScaleTau(tau, ws.m, force, status, skip);
}

ISOWRENCH_CLONES void LaneBroadcast(const Data& scalar, LaneWorkspace& workspace) {
  const Data::Impl& s = scalar.impl();
  const int S = s.size.stride;
  WithLaneShape(s.size.large, workspace.impl(), [&](auto& ws) {
    V* J = ws.JacobianData();
    const int js = ws.JacobianStride();
    for (int k = 0; k < ws.m; ++k) {
      for (int r = 0; r < 6; ++r) J[r * js + k] = ISOWRENCH_V4_SPLAT(s.Jr[r * S + k]);
      ws.TauData()[k] = ISOWRENCH_V4_SPLAT(s.tau[k]);
    }
  });
}

namespace {

// The kernel's statics on the lanes (N > 0: m fixed at compile time; N < 0: a large chain).
template <int N, class W>
ISOWRENCH_INLINE void LaneCholesky(W& ws, int m, const V* s_t, const V* s_p, double tolerance,
                                   V* wrench, VI& undecided) {
  kernel::CholeskyScratch<V> scratch;
  if constexpr (W::kLarge) {
    scratch = {ws.inv_diag_scratch.data(), ws.y_scratch.data()};
  }
  kernel::Cholesky<N, false>(m, ws.JacobianData(), static_cast<const V*>(nullptr),
                             ws.JacobianStride(), s_t, s_p, ws.TauData(), tolerance, &ws.U[0],
                             ws.kUStride, &ws.x[0], wrench, undecided, scratch);
}

// LaneSolve on the workspace's shape (its sets already in ws.s_t, s_p): the undecided lanes.
// (Masks are written through references, not returned: a 32-byte vector returned by value
// changes the ABI without AVX, and the large chain's function below is called from a clone.)
template <class W>
ISOWRENCH_INLINE void LaneSolveOf(W& ws, const V* s_t, const V* s_p, double tolerance, V* wrench,
                                  VI& undecided) {
  const int m = ws.m;
  if constexpr (W::kLarge) {
    LaneCholesky<-1>(ws, m, s_t, s_p, tolerance, wrench, undecided);
  } else {
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
  }
}

ISOWRENCH_CLONES ISOWRENCH_NOINLINE void LargeLaneSolve(LargeLanes& ws, const V* s_t, const V* s_p,
                                                        double tolerance, V* wrench,
                                                        VI& undecided) {
  LaneSolveOf(ws, s_t, s_p, tolerance, wrench, undecided);
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneSolve(const Model& model, LaneWorkspace& workspace,
                                    const StiffnessSet* const sets[kLanes],
                                    const SolveOptions& options, WrenchResult* const out[kLanes]) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const int m = ws.m;  // the model's dof count
  const FlatChain& d = model.impl().flat;
  // Locked coordinates: the scalar path's SolveLocked decides every lane.
  if (d.any_locked) return (1u << kLanes) - 1;
  V* s_t = ws.s_t;
  V* s_p = d.large ? static_cast<LargeLanes&>(ws).s_p.data() : static_cast<SmallLanes&>(ws).s_p;
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
  if (d.large) {
    LargeLaneSolve(static_cast<LargeLanes&>(ws), s_t, s_p, tolerance, wrench, undecided);
  } else {
    LaneSolveOf(static_cast<SmallLanes&>(ws), s_t, s_p, tolerance, wrench, undecided);
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
