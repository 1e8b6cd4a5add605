#pragma once
// Private: the engine, written once over the number type T: T = double evaluates one posture
// (fast.cpp: Data::Impl), T = V4 evaluates four at once, one per SIMD lane (lanes.cpp:
// LaneWorkspace::Impl). The chain's structure (joint types, axes, path point frames) is the
// same in every lane, so every branch below is uniform across lanes; only the numbers differ.
//
// Kinematics (per movable joint k, parent frame (M, o), folded fixed transform (R0, p0)):
//   joint origin  j_k = o + M p0,   M <- M R0,   world axis z_k = M a_k,
//   revolute:  M <- M Rot(a_k, q_k), o_k = j_k;   prismatic: o_k = j_k + z_k q_k.
// Endpoint Jacobian columns (KDL's, reference point p_E, world axes):
//   revolute [z_k x (p_E - o_k); z_k],  prismatic [z_k; 0].
// Muscle: with unit segment directions u_i, dL/dtheta = sum_points Jp(x_i)^T g_i where
// g_i = u_{i-1} - u_i is the "pull" at point i (u_{-1} = u_n = 0). Summing the pulls and their
// moments from the distal end (a backward sweep over joints) gives, per joint k,
//   revolute  dL/dtheta_k = z_k . (sum x_i x g_i - o_k x sum g_i),  prismatic z_k . sum g_i,
// over the points distal to joint k: O(m + points) instead of one point Jacobian per point.
// Coupled chains: the sweep writes each joint's column at its slot (FlatChain::slot: its
// coordinate's column, or a place past the stride), then each driven joint's slot is folded
// into its column, J = J_joints C with C = dq_joint/dq (and dL/dq = C^T dL/dq_joint).
// Statics: K = J^T S_t J + S_p, Cholesky K = U^T U, two triangular solves, W = S_t J dtheta
// (Cholesky).
//
// Vectors and frames are Vec3<T> (fast/vec3.hpp): for one posture x, y, z share one SIMD
// register, for the lanes each component is a lane vector.
//
// A workspace W (fast_impl.hpp: SmallWorkspace or LargeWorkspace; lanes.cpp: the lanes' two)
// provides: `using Scalar = T`; kLarge (its shape: false, fixed-size arrays whose strides are
// compile-time constants; true, buffers sized from the chain); Vec3<T> arrays origin, axis (one
// per movable joint), points, pulls (one per path point), a T array dq_joint (per movable joint;
// coupled chains), frames (3 columns per movable joint; only for kFrames); T length; and
// Resize(columns) before J, dL and tau are written. The lanes also JacobianData() (row-major,
// row r at JacobianData() + r * JacobianStride(), FlatChain::slot_count columns) and TauData()
// (slot_count entries); one posture SetPose(endpoint, R_W_T columns), the column staging
// `staged` (three arrays of slot_count: v at 0, w at kW, the terms of dL/dq at kP;
// FinishColumns reads the first n rounded up to whole groups of 4), J, dL and tau (Jr,
// dL_data, tau_data; row stride kStride), and for a large chain `trig` (sin and cos, cos at
// cos_offset). Where W is a SmallWorkspace its kW, kP and kStride are constants.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "fast/fast_impl.hpp"
#include "fast/one_cylinder.hpp"
#include "fast/simd.hpp"
#include "fast/vec3.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace kernel {

// The one-posture statics reads rows of J, S_t J and U four entries at a time up to the next
// multiple of 4 past m; the row strides (FlatChain::stride) are multiples of 4 at least m.
static_assert(kSmallJoints % 4 == 0, "rows are read in whole 4-double vectors");

/// The result of a comparison (fast/vec3.hpp: LaneTypes).
template <class T>
using Mask = typename LaneTypes<T>::Mask;

template <class T>
inline constexpr bool kScalar = std::is_same_v<T, double>;

ISOWRENCH_INLINE void Sqrt(double x, double& out) { out = std::sqrt(x); }
ISOWRENCH_INLINE void Sqrt(const V4& x, V4& out) {
  for (int l = 0; l < 4; ++l) out[l] = std::sqrt(x[l]);
}

// sin and cos of one angle, to within an ulp or two, in about 50 instructions instead of the
// ~120 of libm's sincos: sincos::Kernel (simd.hpp) and the quadrant, by branches. Angles beyond
// sincos::kMaxReduced fall back to std::sin / std::cos.
ISOWRENCH_INLINE void SinCos(double x, double& sin_x, double& cos_x) {
  if (!(std::abs(x) < sincos::kMaxReduced)) {
    sin_x = std::sin(x);
    cos_x = std::cos(x);
    return;
  }
  const double k = (x * sincos::kTwoOverPi + sincos::kRound) - sincos::kRound;
  const long n = static_cast<long>(k);
  double sin_r, cos_r;
  sincos::Kernel(x, k, sin_r, cos_r);
  // Quadrant n mod 4: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s).
  const bool swap = n & 1;
  const double sign_sin = (n & 2) ? -1.0 : 1.0;
  const double sign_cos = ((n + 1) & 2) ? -1.0 : 1.0;
  sin_x = sign_sin * (swap ? cos_r : sin_r);
  cos_x = sign_cos * (swap ? sin_r : cos_r);
}

// The same per lane, with the quadrant read from the low bits of x 2/pi + 1.5 * 2^52 (its
// mantissa holds round(x 2/pi), two's complement modulo 4) and applied by selects and sign-bit
// flips. Valid for |x| < sincos::kMaxReduced: LaneKinematics hands lanes with larger angles to
// the scalar path.
template <bool kOpaque = true>
ISOWRENCH_INLINE void SinCos(const V4& x, V4& sin_x, V4& cos_x,
                             const V4* table = sincos::kLaneConstants) {
  const V4 shifted = x * sincos::kTwoOverPi + sincos::kRound;
  const V4i n = (V4i)shifted;  // GCC vector casts keep the bits
  const V4 k = shifted - sincos::kRound;
  V4 sin_r, cos_r;
  sincos::Kernel<kOpaque>(x, k, sin_r, cos_r, table);
  const V4i swap = (n & 1) != 0;
  const V4 s = swap ? cos_r : sin_r;
  const V4 c = swap ? sin_r : cos_r;
  const V4i sign_sin = (n & 2) << 62;
  const V4i sign_cos = ((n + 1) & 2) << 62;
  sin_x = (V4)((V4i)s ^ sign_sin);
  cos_x = (V4)((V4i)c ^ sign_cos);
}

// The joint's turn M <- M Rot(e_K, q) about coordinate axis K of its frame, given c = cos q and
// s = sin q (kNegative: the axis is -e_K, so the turn is by -q): the two other columns turn.
template <int K, bool kNegative, class T>
ISOWRENCH_INLINE void Turn(Vec3<T>* M, const T& c, const T& s) {
  constexpr int A = (K + 1) % 3, B = (K + 2) % 3;
  const Vec3<T> a = M[A], b = M[B];
  if constexpr (kNegative) {
    M[A] = a * c - b * s;
    M[B] = b * c + a * s;
  } else {
    M[A] = a * c + b * s;
    M[B] = b * c - a * s;
  }
}

// The same for a general unit axis a (Rodrigues: Rot = c I + s [a]x + (1 - c) a a^T, column j
// of M Rot = c M_j + s M (a x e_j) + (1 - c) a_j M a), out of the hot path: no shipped chain
// has one.
template <class T>
ISOWRENCH_NOINLINE void GeneralTurnOutOfLine(Vec3<T>* M, const Eigen::Vector3d& a, const T& c,
                                             const T& s) {
  const Vec3<T> z = Transform(M, a.data());
  const T one_minus_c = 1.0 - c;
  Vec3<T> out[3];
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d a_cross_e = a.cross(Eigen::Vector3d::Unit(j));
    out[j] = M[j] * c + Transform(M, a_cross_e.data()) * s + z * (one_minus_c * a[j]);
  }
  for (int j = 0; j < 3; ++j) M[j] = out[j];
}
// M, c and s go through copies so that the caller's frame and angle never have their address
// taken and stay in registers.
template <class T>
ISOWRENCH_INLINE void GeneralTurn(Vec3<T>* M, const Eigen::Vector3d& a, const T& c, const T& s) {
  Vec3<T> copy[3] = {M[0], M[1], M[2]};
  const T cs[2] = {c, s};
  GeneralTurnOutOfLine(copy, a, cs[0], cs[1]);
  ISOWRENCH_UNROLL
  for (int j = 0; j < 3; ++j) M[j] = copy[j];
}

// One posture: sin and cos of the joint positions q[k] of the joints FlatChain::trig_begin ..
// trig_end - 1 (every revolute joint; for the others the numbers are not used) ahead of the
// joint loop, four joints per vector SinCos (joints with |q| >= sincos::kMaxReduced one by
// one). The lanes call their vector SinCos inside the joint loop. kOpaque: the constants read
// in the loop from the lanes' table through an address GCC cannot follow, instead of known
// values, which GCC lifts out of the loop into registers and, in the one-cylinder kernel
// (kWrap), spills (37 instructions more than the loop's own).
template <bool kOpaque = false>
ISOWRENCH_INLINE void JointSinCos(const FlatChain& d, const double* q, double* sin_q,
                                  double* cos_q) {
  const int end = d.trig_end;
  for (int k0 = d.trig_begin; k0 < end; k0 += 4) {
    V4 x, s, c;
    if (k0 + 4 <= end) {
      std::memcpy(&x, q + k0, sizeof x);
    } else {  // the last 1 to 3 joints, padded with zeros (element by element: GCC would turn
              // a copy loop into a call to memcpy)
      x = V4{q[k0], k0 + 1 < end ? q[k0 + 1] : 0.0, k0 + 2 < end ? q[k0 + 2] : 0.0, 0.0};
    }
    const V4 magnitude = (V4)((V4i)x & 0x7fffffffffffffff);
    const V4i reduced = magnitude < sincos::kMaxReduced;
    const V4* table = sincos::kLaneConstants;
    if constexpr (kOpaque) asm volatile("" : "+r"(table));
    SinCos<kOpaque>(x, s, c, table);
    std::memcpy(sin_q + k0, &s, sizeof s);
    std::memcpy(cos_q + k0, &c, sizeof c);
    // A lane beyond the reduction's range (the four lanes' masks and-ed in the vector): those
    // four joints one by one.
    const V4i pairs = reduced & __builtin_shufflevector(reduced, reduced, 2, 3, 0, 1);
    if (!(pairs & __builtin_shufflevector(pairs, pairs, 1, 0, 3, 2))[0]) {
      for (int k = k0; k < std::min(end, k0 + 4); ++k) SinCos(q[k], sin_q[k], cos_q[k]);
    }
  }
}
/// The point groups of a muscle without path points (FastMuscle), for any chain: the sentinels.
inline constexpr int kNoForwardPoints[1] = {std::numeric_limits<int>::max()};
inline constexpr int kNoBackwardPoints[1] = {-1};

/// One movable joint of the forward kinematics, compiled for its kind OP (FastJoint::op, 64
/// kinds): the frame (M, o) moves to the joint (fixed transform), z = its world axis, and the
/// joint turns M (revolute) or moves o along z (prismatic). One posture reads sin q and cos q
/// from sc[0] and sc[cos_offset] (JointSinCos); the lanes compute them.
template <int OP, class T>
ISOWRENCH_INLINE void JointStep(const FastJoint& j, Vec3<T>* M, Vec3<T>& o, Vec3<T>& z, const T& qk,
                                const double* sc, int cos_offset) {
  constexpr bool kRevolute = (OP & 1) != 0;
  constexpr int kAxis = (OP >> 1) & 3;        // 0/1/2: x/y/z, 3: general
  constexpr bool kNegative = (OP & 32) != 0;  // -x/-y/-z
  if constexpr ((OP & 8) != 0) o = o + Transform(M, j.origin_translation.data());
  if constexpr ((OP & 16) != 0) MultiplyRotation(M, j.origin_rotation);
  if constexpr (kAxis == 3) {
    z = Transform(M, j.axis.data());
  } else if constexpr (kNegative) {
    z = -M[kAxis];
  } else {
    z = M[kAxis];
  }
  if constexpr (kRevolute) {
    T s, c;
    if constexpr (kScalar<T>) {
      s = sc[0];
      c = sc[cos_offset];
    } else {
      SinCos(qk, s, c);
    }
    if constexpr (kAxis == 3) {
      GeneralTurn(M, j.axis, c, s);
    } else {
      Turn<kAxis, kNegative>(M, c, s);
    }
  } else {
    o = o + z * qk;
  }
}

/// One posture: the columns the backward sweep staged (ws.staged: the columns' v and w in
/// world axes, and the x, y and z terms of dL/dq) moved into J (row-major, turned into
/// transducer axes when `rotate`), dL/dq and tau, four columns per step: a 4 x 4 transpose of
/// the staged vectors gives four entries of a row at once.
template <class W>
ISOWRENCH_INLINE void FinishColumns(W& ws, int n, const V4* Rt, bool rotate, double minus_force) {
  // Rows x, y, z (lanes: columns c0 .. c0 + 3) of four staged vectors.
  auto rows = [](const V4* s, V4* out) ISOWRENCH_LAMBDA_INLINE {
    const V4 t0 = __builtin_shufflevector(s[0], s[1], 0, 4, 2, 6);
    const V4 t1 = __builtin_shufflevector(s[0], s[1], 1, 5, 3, 7);
    const V4 t2 = __builtin_shufflevector(s[2], s[3], 0, 4, 2, 6);
    const V4 t3 = __builtin_shufflevector(s[2], s[3], 1, 5, 3, 7);
    out[0] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
    out[1] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
    out[2] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  };
  const int S = ws.kStride;
  double* J = ws.Jr.data();
  double* dL = ws.dL_data.data();
  double* tau = ws.tau_data.data();
  // Compiled once with and once without the turn, so that the turn's setup (R_W_T's entries in
  // whole vectors) happens only when it is used.
  auto all_columns = [&](auto rotate_tag) ISOWRENCH_LAMBDA_INLINE {
    for (int c0 = 0; c0 < n; c0 += 4) {
      V4 r[6], p[3];
      rows(&ws.staged[c0], r);
      rows(&ws.staged[ws.kW + c0], r + 3);
      rows(&ws.staged[ws.kP + c0], p);
      if constexpr (decltype(rotate_tag)::value) {  // R_W_T^T [v; w]: row i = sum_k R_ki row k
        V4 t[6];
        ISOWRENCH_UNROLL
        for (int i = 0; i < 3; ++i) {
          const V4& R_i = Rt[i];  // column i of R_W_T
          t[i] = (r[0] * R_i[0] + r[1] * R_i[1]) + r[2] * R_i[2];
          t[3 + i] = (r[3] * R_i[0] + r[4] * R_i[1]) + r[5] * R_i[2];
        }
        ISOWRENCH_UNROLL
        for (int i = 0; i < 6; ++i) r[i] = t[i];
      }
      ISOWRENCH_UNROLL
      for (int i = 0; i < 6; ++i) std::memcpy(J + i * S + c0, &r[i], sizeof(V4));
      const V4 dl = (p[0] + p[1]) + p[2];
      const V4 t = dl * minus_force;
      std::memcpy(dL + c0, &dl, sizeof dl);
      std::memcpy(tau + c0, &t, sizeof t);
    }
  };
  if (rotate) {
    all_columns(std::true_type{});
  } else {
    all_columns(std::false_type{});
  }
}

/// Forward kinematics, the endpoint Jacobian (world axes, turned into transducer axes when
/// `rotate`) and the length, dL/dq and tau = minus_force dL/dq of muscle `mu`, at joint
/// positions q (d.m entries; on a coupled chain ws.dq_joint holds dq_joint/dq). Sets
/// `coincident` on the lanes where two consecutive path points coincide (their dL and tau are
/// not meaningful; the scalar path sets them to 0). Masks are written through references, not
/// returned: a 32-byte vector returned by value changes the ABI without AVX (-Wpsabi).
/// kFrames: also store each movable joint's world rotation in ws.frames (the public kinematics
/// functions). kDynamic (scalar only): the muscle has moving or conditional points
/// (src/fast/path_points.cpp); ws.local and ws.active were prepared by PreparePathPoints.
/// kCoupled: any chain, with or without couplings (each joint writes its slot, then the folds;
/// ws.dq_joint is read); false: only a chain without couplings (!d.coupled: joint k writes
/// column k), compiled apart so that such chains run none of the coupled steps.
/// kWrap (scalar only, not with kDynamic): a muscle over one cylinder with fixed points
/// (FastMuscle::one_cylinder): the points placed as fixed ones, the rotation of the cylinder's
/// frame stored at its first slot (ws.point_rotation), and the path stage OneCylinderPathPulls.
template <bool kFrames, bool kDynamic, bool kCoupled, bool kWrap = false, class W,
          class T = typename W::Scalar>
ISOWRENCH_INLINE void Kinematics(const FlatChain& d, W& ws, const T* q, const FastMuscle& mu,
                                 double minus_force, bool rotate, Mask<T>& coincident) {
  static_assert(kScalar<T> || (!kFrames && !kDynamic && !kWrap),
                "frames, moving points and wraps: scalar only");
  static_assert(!(kDynamic && kWrap), "kWrap is the fixed points' wrap");
  assert(kCoupled || !d.coupled);
  using V3 = Vec3<T>;
  const int m = d.m;
  const FastJoint* joints = d.joints.data();
  const int n = static_cast<int>(mu.points.size());
  const FastPathPoint* pts = mu.points.data();
  // The groups of points by frame (FastMuscle::forward_points, backward_points); a muscle of the
  // public kinematics functions' "no muscle" has none.
  const int* forward = mu.forward_points.empty() ? kNoForwardPoints : mu.forward_points.data();
  const int* backward = mu.backward_points.empty() ? kNoBackwardPoints : mu.backward_points.data();
  if constexpr (kWrap) backward = mu.one_cylinder_backward_points.data();  // (no slots)
  const T zero = T{};

  // Path points on ground are fixed in world; the others are placed as soon as their frame is
  // known, so that no frame is stored.
  for (const int i : mu.ground_points) {
    if constexpr (kDynamic) {
      ws.point_rotation[i][0] = Unit3<T>(0);
      ws.point_rotation[i][1] = Unit3<T>(1);
      ws.point_rotation[i][2] = Unit3<T>(2);
      ws.points[i] = Constant3<T>(ws.local[i].data());
    } else {
      ws.points[i] = Constant3<T>(pts[i].position.data());
    }
  }

  // The current frame lives in locals (registers): rotation M (three columns) and origin o; it
  // starts as the world frame.
  // One posture: sin q_k at sin_q[k], cos q_k at sin_q[cos_offset + k] (+ 4: JointSinCos
  // writes whole vectors); on the stack for a small chain, in the workspace for a large one.
  double sin_small[W::kLarge ? 1 : 2 * (kSmallJoints + 4)];
  double* sin_q = sin_small;
  int cos_offset = kSmallJoints + 4;
  if constexpr (W::kLarge && kScalar<T>) {
    sin_q = ws.trig.data();
    cos_offset = ws.cos_offset;
  }
  if constexpr (kScalar<T>) JointSinCos<kWrap>(d, q, sin_q, sin_q + cos_offset);
  V3 M[3] = {Unit3<T>(0), Unit3<T>(1), Unit3<T>(2)};
  V3 o = Zero3<T>();
  [[maybe_unused]] int wrap_frame = -1, wrap_slot = 0;
  if constexpr (kWrap) {
    wrap_frame = mu.wrap_frame;
    wrap_slot = mu.wraps[0].slot;
    if (wrap_frame < 0) {
      ISOWRENCH_UNROLL
      for (int c = 0; c < 3; ++c) ws.point_rotation[wrap_slot][c] = M[c];
    }
  }
  for (int k = 0; k < m; ++k) {
    const FastJoint& j = joints[k];
    V3& z = ws.axis[k];
    const T qk = q[k];
    const double* sc = sin_q + k;  // one posture: sin q_k, and cos q_k at sc[cos_offset]
    switch (j.op) {  // one jump per joint to the step compiled for its kind (JointStep)
      case 0: JointStep<0>(j, M, o, z, qk, sc, cos_offset); break;
      case 1: JointStep<1>(j, M, o, z, qk, sc, cos_offset); break;
      case 2: JointStep<2>(j, M, o, z, qk, sc, cos_offset); break;
      case 3: JointStep<3>(j, M, o, z, qk, sc, cos_offset); break;
      case 4: JointStep<4>(j, M, o, z, qk, sc, cos_offset); break;
      case 5: JointStep<5>(j, M, o, z, qk, sc, cos_offset); break;
      case 6: JointStep<6>(j, M, o, z, qk, sc, cos_offset); break;
      case 7: JointStep<7>(j, M, o, z, qk, sc, cos_offset); break;
      case 8: JointStep<8>(j, M, o, z, qk, sc, cos_offset); break;
      case 9: JointStep<9>(j, M, o, z, qk, sc, cos_offset); break;
      case 10: JointStep<10>(j, M, o, z, qk, sc, cos_offset); break;
      case 11: JointStep<11>(j, M, o, z, qk, sc, cos_offset); break;
      case 12: JointStep<12>(j, M, o, z, qk, sc, cos_offset); break;
      case 13: JointStep<13>(j, M, o, z, qk, sc, cos_offset); break;
      case 14: JointStep<14>(j, M, o, z, qk, sc, cos_offset); break;
      case 15: JointStep<15>(j, M, o, z, qk, sc, cos_offset); break;
      case 16: JointStep<16>(j, M, o, z, qk, sc, cos_offset); break;
      case 17: JointStep<17>(j, M, o, z, qk, sc, cos_offset); break;
      case 18: JointStep<18>(j, M, o, z, qk, sc, cos_offset); break;
      case 19: JointStep<19>(j, M, o, z, qk, sc, cos_offset); break;
      case 20: JointStep<20>(j, M, o, z, qk, sc, cos_offset); break;
      case 21: JointStep<21>(j, M, o, z, qk, sc, cos_offset); break;
      case 22: JointStep<22>(j, M, o, z, qk, sc, cos_offset); break;
      case 23: JointStep<23>(j, M, o, z, qk, sc, cos_offset); break;
      case 24: JointStep<24>(j, M, o, z, qk, sc, cos_offset); break;
      case 25: JointStep<25>(j, M, o, z, qk, sc, cos_offset); break;
      case 26: JointStep<26>(j, M, o, z, qk, sc, cos_offset); break;
      case 27: JointStep<27>(j, M, o, z, qk, sc, cos_offset); break;
      case 28: JointStep<28>(j, M, o, z, qk, sc, cos_offset); break;
      case 29: JointStep<29>(j, M, o, z, qk, sc, cos_offset); break;
      case 30: JointStep<30>(j, M, o, z, qk, sc, cos_offset); break;
      case 31: JointStep<31>(j, M, o, z, qk, sc, cos_offset); break;
      case 32: JointStep<32>(j, M, o, z, qk, sc, cos_offset); break;
      case 33: JointStep<33>(j, M, o, z, qk, sc, cos_offset); break;
      case 34: JointStep<34>(j, M, o, z, qk, sc, cos_offset); break;
      case 35: JointStep<35>(j, M, o, z, qk, sc, cos_offset); break;
      case 36: JointStep<36>(j, M, o, z, qk, sc, cos_offset); break;
      case 37: JointStep<37>(j, M, o, z, qk, sc, cos_offset); break;
      case 38: JointStep<38>(j, M, o, z, qk, sc, cos_offset); break;
      case 39: JointStep<39>(j, M, o, z, qk, sc, cos_offset); break;
      case 40: JointStep<40>(j, M, o, z, qk, sc, cos_offset); break;
      case 41: JointStep<41>(j, M, o, z, qk, sc, cos_offset); break;
      case 42: JointStep<42>(j, M, o, z, qk, sc, cos_offset); break;
      case 43: JointStep<43>(j, M, o, z, qk, sc, cos_offset); break;
      case 44: JointStep<44>(j, M, o, z, qk, sc, cos_offset); break;
      case 45: JointStep<45>(j, M, o, z, qk, sc, cos_offset); break;
      case 46: JointStep<46>(j, M, o, z, qk, sc, cos_offset); break;
      case 47: JointStep<47>(j, M, o, z, qk, sc, cos_offset); break;
      case 48: JointStep<48>(j, M, o, z, qk, sc, cos_offset); break;
      case 49: JointStep<49>(j, M, o, z, qk, sc, cos_offset); break;
      case 50: JointStep<50>(j, M, o, z, qk, sc, cos_offset); break;
      case 51: JointStep<51>(j, M, o, z, qk, sc, cos_offset); break;
      case 52: JointStep<52>(j, M, o, z, qk, sc, cos_offset); break;
      case 53: JointStep<53>(j, M, o, z, qk, sc, cos_offset); break;
      case 54: JointStep<54>(j, M, o, z, qk, sc, cos_offset); break;
      case 55: JointStep<55>(j, M, o, z, qk, sc, cos_offset); break;
      case 56: JointStep<56>(j, M, o, z, qk, sc, cos_offset); break;
      case 57: JointStep<57>(j, M, o, z, qk, sc, cos_offset); break;
      case 58: JointStep<58>(j, M, o, z, qk, sc, cos_offset); break;
      case 59: JointStep<59>(j, M, o, z, qk, sc, cos_offset); break;
      case 60: JointStep<60>(j, M, o, z, qk, sc, cos_offset); break;
      case 61: JointStep<61>(j, M, o, z, qk, sc, cos_offset); break;
      case 62: JointStep<62>(j, M, o, z, qk, sc, cos_offset); break;
      case 63: JointStep<63>(j, M, o, z, qk, sc, cos_offset); break;
      default: __builtin_unreachable();
    }
    ws.origin[k] = o;
    if constexpr (kFrames) {
      ISOWRENCH_UNROLL
      for (int c = 0; c < 3; ++c) ws.frames[k][c] = M[c];
    }
    if (k != forward[0]) continue;  // frame k has no points
    if constexpr (kWrap) {          // (the cylinder's frame has points: its slots)
      if (k == wrap_frame) {
        ISOWRENCH_UNROLL
        for (int c = 0; c < 3; ++c) ws.point_rotation[wrap_slot][c] = M[c];
      }
    }
    const int* group_end = forward + 2 + forward[1];
    for (const int* point = forward + 2; point < group_end; ++point) {  // x = M a + o
      const int i = *point;
      if constexpr (kDynamic) {
        ISOWRENCH_UNROLL
        for (int c = 0; c < 3; ++c) ws.point_rotation[i][c] = M[c];
        ws.points[i] = Transform(M, ws.local[i].data()) + o;
      } else {
        ws.points[i] = Transform(M, pts[i].position.data()) + o;
      }
    }
    forward = group_end;
  }
  // Endpoint and R_W_T in locals: the stores below cannot alias them.
  const V3 pe = Transform(M, d.endpoint.data()) + o;
  V3 Rt[3];  // the lanes need it only to turn J (their workspace keeps no endpoint or R_W_T)
  if (!kScalar<T> && !rotate) {
    Rt[0] = Rt[1] = Rt[2] = Zero3<T>();
  } else if (d.transducer_identity) {
    ISOWRENCH_UNROLL
    for (int c = 0; c < 3; ++c) Rt[c] = Unit3<T>(c);
  } else if (d.transducer_in_world) {
    ISOWRENCH_UNROLL
    for (int c = 0; c < 3; ++c) Rt[c] = Constant3<T>(d.transducer_rotation.data() + 3 * c);
  } else {
    ISOWRENCH_UNROLL
    for (int c = 0; c < 3; ++c) Rt[c] = M[c];
    MultiplyRotation(Rt, d.transducer_rotation);
  }
  if constexpr (kScalar<T>) ws.SetPose(pe, Rt);
  ws.Resize(d.n);

  // Muscle: unit segment directions and pulls (over the active points only for a muscle with
  // moving or conditional points).
  coincident = Mask<T>{};
  T total_length = zero;
  // kWrap: the tangent-point slots' summed pull and moment, added at the cylinder's frame.
  [[maybe_unused]] V3 slot_pull, slot_moment;
  if constexpr (kDynamic) {
    double length = 0.0;
    coincident = !DynamicPathPulls(d, mu, ws, &length);
    total_length = length;
  } else if constexpr (kWrap) {
    double length = 0.0;
    coincident = !OneCylinderPathPulls(mu, ws, &length, slot_pull, slot_moment);
    total_length = length;
  } else {
    V3 before = Zero3<T>();  // u_{i-1}; zero before the origin
    for (int i = 1; i < n; ++i) {
      const V3 s = ws.points[i] - ws.points[i - 1];
      T length_squared, length;
      Dot(s, s, length_squared);
      Sqrt(length_squared, length);
      coincident |= (length >= kFastMinSegmentLength) == 0;
      const T inv = 1.0 / length;
      const V3 u = s * inv;
      total_length += length;
      ws.pulls[i - 1] = before - u;
      Set(before, u);
    }
    if (n > 0) ws.pulls[n - 1] = before;
  }
  ws.length = total_length;

  // Backward sweep over the joints: the Jacobian column and dL/dtheta_k of each joint. One
  // posture stages each column in world axes (ws.staged: v, w and the terms of the dot product
  // dL/dq) and FinishColumns moves them into J, dL and tau four columns at a time; the lanes
  // write them directly. On a coupled chain joint k writes slot d.slot[k] (its column, or a
  // place past the stride that a fold adds into its column after the sweep).
  V3 ps = Zero3<T>();  // sum of pulls distal to joint k
  V3 ms = Zero3<T>();  // sum of their moments about the world origin
  T* J = nullptr;      // the lanes' J (row-major, row r at J + r * js) and tau
  int js = 0;
  T* tau = nullptr;
  if constexpr (!kScalar<T>) {
    J = ws.JacobianData();
    js = ws.JacobianStride();
    tau = ws.TauData();
  }
  // The sweep compiled with and without J turned into transducer axes (the same for every
  // joint).
  auto sweep = [&](auto rotate_tag) ISOWRENCH_LAMBDA_INLINE {
    constexpr bool kRotate = decltype(rotate_tag)::value;
    V3 RtT[3];  // the lanes turn each column: R_W_T^T v = RtT v
    if constexpr (kRotate && !kScalar<T>) Transpose(Rt, RtT);
    const std::uint32_t revolute_mask = d.revolute_mask;                // a small chain's joints
    [[maybe_unused]] const std::uint8_t* revolute = d.revolute.data();  // a large chain's
    // Joint k: its points' pulls and moments, then its column into slot s.
    auto joint = [&](int k, int s) ISOWRENCH_LAMBDA_INLINE {
      if (k == backward[0]) {  // the points of frame k
        const int* group_end = backward + 2 + backward[1];
        for (const int* point = backward + 2; point < group_end; ++point) {
          const V3& g = ws.pulls[*point];
          ps += g;
          ms += Cross(ws.points[*point], g);
        }
        if constexpr (kWrap) {
          if (k == wrap_frame) {
            ps += slot_pull;
            ms += slot_moment;
          }
        }
        backward = group_end;
      }
      // Vectors of the lanes' workspace are read through references: a local copy of a Lanes3
      // (96 bytes, no vector mode) is made through the stack.
      const V3& z = ws.axis[k];
      // Joint k's column [v; w] (world axes) and dL/dtheta_k = z . b into slot s of J and tau
      // (the lanes) or of the staging (one posture); called in each branch below, so that no
      // value is merged.
      auto put = [&](const V3& v, const V3& w, const V3& b,
                     auto revolute_tag) ISOWRENCH_LAMBDA_INLINE {
        constexpr bool kRevolute = decltype(revolute_tag)::value;
        if constexpr (kScalar<T>) {  // staged in world axes; FinishColumns turns them
          V3* col = &ws.staged[s];
          col[0] = v;
          col[ws.kW] = w;
          col[ws.kP] = Hadamard(z, b);
        } else {
          T dl;
          Dot(z, b, dl);
          // (a prismatic column's angular rows are 0, written each time: a fold may have added
          // to an owner's column)
          auto store = [&](const V3& vt, const V3& wt) ISOWRENCH_LAMBDA_INLINE {
            T* col = J + s;
            ISOWRENCH_UNROLL
            for (int r = 0; r < 3; ++r) {
              col[r * js] = Component(vt, r);
              col[(3 + r) * js] = kRevolute ? Component(wt, r) : zero;
            }
            tau[s] = minus_force * dl;
          };
          if constexpr (kRotate) {
            store(Rotate(RtT, v), Rotate(RtT, w));
          } else {
            store(v, w);
          }
        }
      };
      bool is_revolute;
      if constexpr (W::kLarge) {
        is_revolute = revolute[k] != 0;
      } else {
        is_revolute = ((revolute_mask >> k) & 1u) != 0;
      }
      if (is_revolute) {
        const V3& ok = ws.origin[k];
        put(Cross(z, pe - ok), z, ms - Cross(ok, ps), std::true_type{});
      } else {
        put(z, Zero3<T>(), ps, std::false_type{});
      }
    };
    // With couplings the joints from FlatChain::plain_joints on read their slots; the ones
    // before write column k, as without couplings.
    const int plain = kCoupled ? d.plain_joints : 0;
    const int* slots = d.slot.data();
    for (int k = m - 1; k >= plain; --k) joint(k, kCoupled ? slots[k] : k);
    for (int k = plain - 1; k >= 0; --k) joint(k, k);
  };
  if (rotate) {
    sweep(std::true_type{});
  } else {
    sweep(std::false_type{});
  }
  // Coupled chains: each slot past the stride into its column, J = J_joints C and the same for
  // dL/dq (one posture: the staged terms) or tau (the lanes); columns no joint drives are 0.
  if constexpr (kCoupled) {
    for (const FlatChain::DrivenJoint& f : d.driven_joints) {
      const T c = ws.dq_joint[f.joint];
      if constexpr (kScalar<T>) {
        const V3* from = &ws.staged[f.slot];
        V3* to = &ws.staged[f.column];
        ISOWRENCH_UNROLL
        for (const int i : {0, int(ws.kW), int(ws.kP)}) {
          if (f.set) {
            to[i] = from[i] * c;
          } else {
            to[i] += from[i] * c;
          }
        }
      } else {
        T* to = J + f.column;
        const T* from = J + f.slot;
        if (f.set) {
          ISOWRENCH_UNROLL
          for (int r = 0; r < 6; ++r) to[r * js] = c * from[r * js];
          tau[f.column] = c * tau[f.slot];
        } else {
          ISOWRENCH_UNROLL
          for (int r = 0; r < 6; ++r) to[r * js] += c * from[r * js];
          tau[f.column] += c * tau[f.slot];
        }
      }
    }
    for (const int c : d.undriven_columns) {
      if constexpr (kScalar<T>) {
        ws.staged[c] = ws.staged[ws.kW + c] = ws.staged[ws.kP + c] = Zero3<T>();
      } else {
        tau[c] = zero;
        for (int r = 0; r < 6; ++r) J[r * js + c] = zero;
      }
    }
  }
  if constexpr (kScalar<T>) FinishColumns(ws, d.n, Rt, rotate, minus_force);
}

/// How a Row update combines a x_i with entry i: e_i = a x_i, e_i += a x_i or e_i -= a x_i.
enum class RowUpdate { kSet, kAdd, kSubtract };

template <RowUpdate kHow, class V>
ISOWRENCH_INLINE void Combine(V& e, const V& product) {
  if constexpr (kHow == RowUpdate::kSet) {
    e = product;
  } else if constexpr (kHow == RowUpdate::kAdd) {
    e += product;
  } else {
    e -= product;
  }
}

/// One row of the statics (entries 0 .. N - 1, N > 0; N = 0: kSmallJoints entries, the first m
/// used), for the row-by-row Cholesky of a small chain below (a large one: LargeFactor). The lanes
/// (T = V4) hold one lane vector per entry; one posture (T = double) holds four entries per V4, so
/// that a row update is one vector multiply-add per four entries. Operations act on the entries i
/// >= from (for T = double from the start of the V4 holding entry `from`: the entries below it in
/// that vector are computed too and never read). Rows read from memory (J, U) are stored with
/// consecutive entries; for T = double a row may be read up to the next multiple of 4 past m (the
/// callers' buffers hold those entries; their values are never used).
template <int N, class T, bool kVectorised = kScalar<T>>
struct Row {
  static constexpr int kEntries = N > 0 ? N : kSmallJoints;
  T e[kEntries];
  /// e_i (=, +=, -=) a x_i for i in [from, m).
  template <RowUpdate kHow>
  ISOWRENCH_INLINE void Update(const T& a, const T* x, int from, int m) {
    ISOWRENCH_UNROLL
    for (int i = from; i < m; ++i) Combine<kHow>(e[i], a * x[i]);
  }
  ISOWRENCH_INLINE void Get(int i, T& out) const { out = e[i]; }
  /// out_i = s e_i.
  ISOWRENCH_INLINE void StoreScaled(T* out, const T& s, int from, int m) const {
    ISOWRENCH_UNROLL
    for (int i = from; i < m; ++i) out[i] = e[i] * s;
  }
};

template <int N>
struct Row<N, double, true> {
  static constexpr int kChunks = (N > 0 ? N + 3 : kSmallJoints) / 4;
  V4 e[kChunks];
  template <RowUpdate kHow>
  ISOWRENCH_INLINE void Update(double a, const double* x, int from, int m) {
    const V4 av = ISOWRENCH_V4_SPLAT(a);
    ISOWRENCH_UNROLL
    for (int c = from / 4; c < (m + 3) / 4; ++c) {
      V4 xv;
      std::memcpy(&xv, x + 4 * c, sizeof xv);
      Combine<kHow>(e[c], av * xv);
    }
  }
  ISOWRENCH_INLINE void Get(int i, double& out) const { out = e[i / 4][i % 4]; }
  ISOWRENCH_INLINE void StoreScaled(double* out, double s, int from, int m) const {
    const V4 sv = ISOWRENCH_V4_SPLAT(s);
    ISOWRENCH_UNROLL
    for (int c = from / 4; c < (m + 3) / 4; ++c) {
      const V4 v = e[c] * sv;
      std::memcpy(out + 4 * c, &v, sizeof v);
    }
  }
};

/// The Cholesky's buffers for a large chain (N < 0): the reciprocal diagonal and the forward
/// substitution (m each). A small chain keeps them on the stack (nullptr).
template <class T>
struct CholeskyScratch {
  T* inv_diag = nullptr;
  T* y = nullptr;
};

/// One posture: wrench_r = sum_j sJ_rj x_j for the 6 rows of S_t J (row r at sJ + r * js), four
/// entries per vector product and the six sums reduced together (two 4 x 4 partial transposes);
/// x is read in whole vectors up to 4 ceil(m / 4) (entries from m on are set to 0 first).
/// `undecided` is set when a sum is not finite.
template <int N>
ISOWRENCH_INLINE void ScaledRowsTimes(int m_runtime, const double* sJ, int js, double* x,
                                      double* wrench, bool& undecided) {
  const int m = N > 0 ? N : m_runtime;
  const int chunks = (m + 3) / 4;
  ISOWRENCH_UNROLL
  for (int j = m; j < 4 * chunks; ++j) x[j] = 0.0;
  V4 p[6];
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    V4 a, b;
    std::memcpy(&a, sJ + r * js, sizeof a);
    std::memcpy(&b, x, sizeof b);
    p[r] = a * b;
    ISOWRENCH_UNROLL
    for (int c = 1; c < chunks; ++c) {
      std::memcpy(&a, sJ + r * js + 4 * c, sizeof a);
      std::memcpy(&b, x + 4 * c, sizeof b);
      p[r] += a * b;
    }
  }
  // Pairwise sums of rows (0, 1), (2, 3), (4, 5), then the halves: lanes of w0123 = W_0 .. W_3,
  // lanes 0 and 1 of w45 = W_4, W_5.
  const V4 h01 = __builtin_shufflevector(p[0], p[1], 0, 4, 2, 6) +
                 __builtin_shufflevector(p[0], p[1], 1, 5, 3, 7);
  const V4 h23 = __builtin_shufflevector(p[2], p[3], 0, 4, 2, 6) +
                 __builtin_shufflevector(p[2], p[3], 1, 5, 3, 7);
  const V4 h45 = __builtin_shufflevector(p[4], p[5], 0, 4, 2, 6) +
                 __builtin_shufflevector(p[4], p[5], 1, 5, 3, 7);
  const V4 w0123 =
      __builtin_shufflevector(h01, h23, 0, 1, 4, 5) + __builtin_shufflevector(h01, h23, 2, 3, 6, 7);
  const V4 w45 = h45 + __builtin_shufflevector(h45, h45, 2, 3, 0, 1);
  std::memcpy(wrench, &w0123, sizeof w0123);
  wrench[4] = w45[0];
  wrench[5] = w45[1];
  const V4 nonfinite = 0.0 * w0123 + 0.0 * w45;  // 0 where finite, NaN where not
  undecided |= ((nonfinite[0] + nonfinite[1]) + (nonfinite[2] + nonfinite[3])) != 0.0;
}

/// A large chain's rows of the Cholesky (N < 0), in blocks: kGroups groups of row j of K - the
/// sum of the rows of U above it (one posture: a group is 4 consecutive entries, one V4; the
/// lanes: one entry, one lane vector), from group g0 on, kept in registers while every source
/// is added in (the 6 rows of J with their coefficients s_t,r J_rj, then the j rows of U above
/// with U_kj), each source entry read once from memory; then scaled by `inv` and stored into row
/// j of U. One pass over a whole row in memory per source (the small chains' Row, whose rows
/// live in registers) costs several times as many instructions once a row no longer fits.
template <int kGroups, bool kScaled, class T>
ISOWRENCH_INLINE void LargeRowBlock(int j, int g0, const T* J, const T* sJ, int js, const T* s_t,
                                    const T* U, int S, V4* acc) {
  auto load = [](const T* row, int g) ISOWRENCH_LAMBDA_INLINE {
    if constexpr (kScalar<T>) {
      V4 v;
      std::memcpy(&v, row + 4 * g, sizeof v);
      return v;
    } else {
      return row[g];
    }
  };
  auto splat = [](const T& a) ISOWRENCH_LAMBDA_INLINE {
    if constexpr (kScalar<T>) {
      return ISOWRENCH_V4_SPLAT(a);
    } else {
      return a;
    }
  };
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    const V4 a = splat(kScaled ? sJ[r * js + j] : s_t[r] * J[r * js + j]);
    ISOWRENCH_UNROLL
    for (int i = 0; i < kGroups; ++i) {
      const V4 product = a * load(J + r * js, g0 + i);
      acc[i] = r == 0 ? product : acc[i] + product;
    }
  }
  const T* u = U;  // row k of U
  for (int k = 0; k < j; ++k, u += S) {
    const V4 a = splat(u[j]);
    ISOWRENCH_UNROLL
    for (int i = 0; i < kGroups; ++i) acc[i] -= a * load(u, g0 + i);
  }
}

/// Stores `count` (1 .. 4) groups `acc` times inv into row j of U from group g0 on.
template <class T>
ISOWRENCH_INLINE void LargeRowStore(int count, int j, int g0, T* U, int S, const V4* acc,
                                    const T& inv) {
  for (int i = 0; i < count; ++i) {
    if constexpr (kScalar<T>) {
      const V4 v = acc[i] * ISOWRENCH_V4_SPLAT(inv);
      std::memcpy(U + j * S + 4 * (g0 + i), &v, sizeof v);
    } else {
      U[j * S + g0 + i] = acc[i] * inv;
    }
  }
}

/// The factor of a large chain (N < 0): rows of U formed block by block (LargeRowBlock, four
/// groups per block; the last block of a row reads up to three groups past the row's end, which
/// the workspaces' J buffers hold and whose sums are not stored), the pivot of row j (from its
/// first block) scaling its blocks. The same sums as the small chains' rows, in the same order
/// per entry.
template <bool kScaled, class T>
ISOWRENCH_INLINE void LargeFactor(int m, const T* J, const T* sJ, int js, const T* s_t,
                                  const T* s_p, T* U, int S, T* inv_diag, T& max_diag,
                                  T& min_pivot) {
  constexpr int kBlock = 4;
  const int groups = kScalar<T> ? (m + 3) / 4 : m;
  for (int j = 0; j < m; ++j) {
    // K_jj (the largest diagonal entry of K judges the pivots): sum_r s_t,r J_rj^2 + s_p,j.
    auto term = [&](int r) ISOWRENCH_LAMBDA_INLINE {
      return (kScaled ? sJ[r * js + j] : s_t[r] * J[r * js + j]) * J[r * js + j];
    };
    T k_jj = term(0);
    for (int r = 1; r < 6; ++r) k_jj += term(r);
    k_jj += s_p[j];
    const int first = kScalar<T> ? j / 4 : j;
    V4 acc[kBlock];
    LargeRowBlock<kBlock, kScaled>(j, first, J, sJ, js, s_t, U, S, acc);
    T dj;
    if constexpr (kScalar<T>) {
      dj = acc[0][j % 4] + s_p[j];
    } else {
      dj = acc[0] + s_p[j];
    }
    max_diag = j == 0 ? k_jj : (k_jj > max_diag ? k_jj : max_diag);
    min_pivot = j == 0 ? dj : (dj < min_pivot ? dj : min_pivot);
    T root;
    Sqrt(dj, root);
    const T inv = 1.0 / root;
    inv_diag[j] = inv;
    // (U_jj is written too, without s_p, and never read, as for small chains)
    LargeRowStore(std::min(kBlock, groups - first), j, first, U, S, acc, inv);
    for (int g = first + kBlock; g < groups; g += kBlock) {
      LargeRowBlock<kBlock, kScaled>(j, g, J, sJ, js, s_t, U, S, acc);
      LargeRowStore(std::min(kBlock, groups - g), j, g, U, S, acc, inv);
    }
  }
}

/// One posture's substitutions for a large chain (U^T U x = b; m at run time), four entries per
/// vector: the forward one by columns (y -= y_k times row k of U, which is contiguous), the
/// backward one by rows (a dot product of row i with x); the first entries up to a multiple of
/// 4 one by one. y and x hold RoundUpTo4(m) entries, x zero past m; U's rows are read up to
/// RoundUpTo4(m) (finite: the factor's padding columns are formed from J's zero columns).
ISOWRENCH_INLINE void LargeSolveWithFactor(int m, const double* U, int S, const double* inv_diag,
                                           const double* b, double* y, double* x) {
  for (int i = 0; i < m; ++i) y[i] = b[i];
  for (int k = 0; k < m; ++k) {
    const double yk = y[k] * inv_diag[k];
    y[k] = yk;
    const double* u = U + k * S;
    int i = k + 1;
    for (; i < m && (i & 3) != 0; ++i) y[i] -= u[i] * yk;
    const V4 a = ISOWRENCH_V4_SPLAT(yk);
    for (; i < m; i += 4) {
      V4 yi, ui;
      std::memcpy(&yi, y + i, sizeof yi);
      std::memcpy(&ui, u + i, sizeof ui);
      yi -= a * ui;
      std::memcpy(y + i, &yi, sizeof yi);
    }
  }
  for (int i = m - 1; i >= 0; --i) {
    const double* u = U + i * S;
    double v = y[i];
    int k = i + 1;
    for (; k < m && (k & 3) != 0; ++k) v -= u[k] * x[k];
    V4 sum = ISOWRENCH_V4_SPLAT(0.0);
    for (; k < m; k += 4) {
      V4 uk, xk;
      std::memcpy(&uk, u + k, sizeof uk);
      std::memcpy(&xk, x + k, sizeof xk);
      sum += uk * xk;
    }
    x[i] = (v - ((sum[0] + sum[1]) + (sum[2] + sum[3]))) * inv_diag[i];
  }
}

/// The statics for one lane type: K = J^T S_t J + S_p, its Cholesky factor U (K = U^T U, row k
/// of U at U[k * us + i], i >= k, us >= RoundUpTo4(m)), dtheta = K^-1 tau into x and W = S_t J
/// dtheta into wrench. Row j of K is formed just before row j of U needs it (K itself is never
/// stored), as one Row: K_j = sum_r (s_t,r J_rj) J_r (rows J_r of J), then K_j - sum_{k<j} U_kj
/// U_k. J: row-major, row r at J + r * js (js >= m; for T = double the buffer must hold 4 ceil(m /
/// 4) entries past the start of the last row, and so must x). kScaled: sJ holds S_t J in the same
/// layout (one posture: each coefficient s_t,r J_rj is then one broadcast from memory, and W is
/// formed four entries of a row at a time by ScaledRowsTimes); else sJ is not read. N > 0 fixes m
/// at compile time (loops unroll); N = 0: m <= kSmallJoints at run time (a small chain: rows on the
/// stack); N < 0: any m (a large chain: rows in `scratch`). Sets `undecided` on the lanes it cannot
/// decide: K not clearly positive definite (a pivot at or below pivot_tolerance times the largest
/// diagonal entry of K; the scalar path then returns before the substitutions, leaving x and wrench
/// unwritten) or a non-finite W.
template <int N, bool kScaled, class T>
ISOWRENCH_INLINE void Cholesky(int m_runtime, const T* J, const T* sJ, int js, const T* s_t,
                               const T* s_p, const T* tau, double pivot_tolerance, T* U, int us,
                               T* x, T* wrench, Mask<T>& undecided,
                               const CholeskyScratch<T>& scratch = {}) {
  const int S = us;
  const int m = N > 0 ? N : (N == 0 ? std::min(m_runtime, kSmallJoints) : m_runtime);
  T max_diag = T{}, min_pivot = T{};
  T inv_local[N < 0 ? 1 : kSmallJoints];
  T* const inv_diag = N < 0 ? scratch.inv_diag : inv_local;
  if constexpr (N < 0) {
    LargeFactor<kScaled>(m, J, sJ, js, s_t, s_p, U, S, inv_diag, max_diag, min_pivot);
  } else {
    ISOWRENCH_UNROLL
    for (int j = 0; j < m; ++j) {
      // Lanes: J and U are read from memory again for each row (a compiler barrier): otherwise
      // GCC keeps every entry of J it loaded live across the unrolled rows and spills them all.
      if constexpr (!kScalar<T>) ISOWRENCH_COMPILER_BARRIER();
      Row<N, T> row{};  // (entries below j are never read; {} for GCC's -Wmaybe-uninitialized)
      row.template Update<RowUpdate::kSet>(kScaled ? sJ[j] : s_t[0] * J[j], J, j, m);
      ISOWRENCH_UNROLL
      for (int r = 1; r < 6; ++r) {
        row.template Update<RowUpdate::kAdd>(kScaled ? sJ[r * js + j] : s_t[r] * J[r * js + j],
                                             J + r * js, j, m);
      }
      T k_jj, dj;
      row.Get(j, k_jj);
      k_jj += s_p[j];
      ISOWRENCH_UNROLL
      for (int k = 0; k < j; ++k)
        row.template Update<RowUpdate::kSubtract>(U[k * S + j], U + k * S, j, m);
      row.Get(j, dj);
      dj += s_p[j];
      // Pivots are judged once K's largest diagonal entry is known (below); a pivot <= 0 makes
      // the rest of this factor NaN or inf, which only the undecided lanes see.
      max_diag = j == 0 ? k_jj : (k_jj > max_diag ? k_jj : max_diag);
      min_pivot = j == 0 ? dj : (dj < min_pivot ? dj : min_pivot);
      T root;
      Sqrt(dj, root);
      const T inv = 1.0 / root;
      inv_diag[j] = inv;
      // U_jj is written too (without s_p: not the factor's diagonal) but never read: the
      // substitutions use inv_diag.
      row.StoreScaled(U + j * S, inv, j, m);
    }
  }
  undecided = (min_pivot > pivot_tolerance * max_diag) == 0;
  if constexpr (kScalar<T>) {
    if (undecided) return;
  }
  // The substitutions read U from memory (a compiler barrier): one posture otherwise extracts
  // its entries from the row vectors still in registers, two or three instructions each.
  if constexpr (kScalar<T>) ISOWRENCH_COMPILER_BARRIER();
  T y_local[N < 0 ? 1 : kSmallJoints];
  T* const y = N < 0 ? scratch.y : y_local;
  if constexpr (N < 0 && kScalar<T>) {
    LargeSolveWithFactor(m, U, S, inv_diag, tau, y, x);
  } else {
    SolveWithFactor<N>(m, U, S, inv_diag, tau, y, x);
  }
  if constexpr (kScalar<T> && kScaled) {
    ScaledRowsTimes<N>(m, sJ, js, x, wrench, undecided);
  } else {
    ISOWRENCH_UNROLL
    for (int r = 0; r < 6; ++r) {
      const T* Jr = (kScaled ? sJ : J) + r * js;
      T v = Jr[0] * x[0];
      ISOWRENCH_UNROLL
      for (int j = 1; j < m; ++j) v += Jr[j] * x[j];
      wrench[r] = kScaled ? v : s_t[r] * v;
      undecided |= (wrench[r] - wrench[r]) != 0.0;  // inf or NaN
    }
  }
}

}  // namespace kernel
}  // namespace isowrench
