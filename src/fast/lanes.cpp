// The lane kernel: ComputeKinematics and SolveStatics written on 4-double vectors (GCC
// vector extensions), one evaluation per lane. The chain's structure (joint types, axes, path
// point frames) is the same in every lane, so every branch below is uniform across lanes; only
// the numbers differ. The formulas are those of fast.cpp (see its header for the kinematics
// and the backward muscle sweep); tests/fast/ prove the lanes equal to the scalar path to
// rounding, including padded and undecided lanes.

#include "fast/lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "fast/fast_impl.hpp"
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

ISOWRENCH_INLINE void Sqrt(const V& x, V& out) {
  for (int l = 0; l < kLanes; ++l) out[l] = std::sqrt(x[l]);
}

// Per-lane sin and cos: the polynomial and Cody-Waite reduction of SinCos in fast.cpp, with the
// quadrant read from the low bits of x 2/pi + 1.5 * 2^52 (its mantissa holds round(x 2/pi),
// two's complement modulo 4) and applied by selects and sign-bit flips instead of branches.
// Valid for |x| < sincos::kMaxReduced; LaneKinematics hands lanes with larger angles to the
// scalar path (which uses std::sin / std::cos there).
ISOWRENCH_INLINE void SinCos(const V& x, V& sin_x, V& cos_x) {
  const V shifted = x * sincos::kTwoOverPi + sincos::kRound;
  const VI n = (VI)shifted;  // GCC vector casts keep the bits
  const V k = shifted - sincos::kRound;
  V sin_r, cos_r;
  sincos::Kernel(x, k, sin_r, cos_r);
  // Quadrant n mod 4: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s).
  const VI swap = (n & 1) != 0;
  const V s = swap ? cos_r : sin_r;
  const V c = swap ? sin_r : cos_r;
  const VI sign_sin = (n & 2) << 62;
  const VI sign_cos = ((n + 1) & 2) << 62;
  sin_x = (V)((VI)s ^ sign_sin);
  cos_x = (V)((VI)c ^ sign_cos);
}

}  // namespace

// Frames are 3 x 3 row-major (R[3 * row + col]); vectors are 3 lanes-vectors.
struct LaneWorkspace::Impl {
  int m = 0;
  V q[kMaxDofs];
  V R[kMaxDofs][9];
  V origin[kMaxDofs][3];
  V axis[kMaxDofs][3];
  V points[kFastMaxPathPoints][3];
  V pulls[kFastMaxPathPoints][3];
  bool frame_needed[kMaxDofs] = {};  // a path point of some muscle hangs on frame k
  V J[kMaxDofs][6];                  // column k: [v; w] in transducer axes
  V tau[kMaxDofs];
  V K[kMaxDofs * kMaxDofs];  // statics: lower triangle of K by rows,
  V U[kMaxDofs * kMaxDofs];  // its Cholesky factor U = L^T (upper triangle by rows)
  V x[kMaxDofs];             // dtheta
};

// The buffers are written before they are read; only the flags are initialised.
LaneWorkspace::LaneWorkspace(const Model& model) : impl_(new Impl) {
  impl_->m = model.dof_count();
  for (const FastMuscle& muscle : model.impl().flat.muscles) {
    for (const FastPathPoint& p : muscle.points) {
      if (p.frame >= 0) impl_->frame_needed[p.frame] = true;
    }
  }
}

LaneWorkspace::~LaneWorkspace() = default;

namespace {

// out = A * c for a lane frame A and a constant vector c.
ISOWRENCH_INLINE void MulConst(const V* A, const Eigen::Vector3d& c, V* out) {
  for (int i = 0; i < 3; ++i) out[i] = A[3 * i] * c[0] + A[3 * i + 1] * c[1] + A[3 * i + 2] * c[2];
}

// out = A^T v for lane frames and vectors.
ISOWRENCH_INLINE void MulTransposed(const V* A, const V* v, V* out) {
  for (int i = 0; i < 3; ++i) out[i] = A[i] * v[0] + A[3 + i] * v[1] + A[6 + i] * v[2];
}

ISOWRENCH_INLINE void Cross(const V* a, const V* b, V* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

// M <- M Rot(axis, q) per lane (RotateFrame in fast.cpp).
ISOWRENCH_INLINE void RotateFrame(const FastJoint& j, const V& q, V* M) {
  V s, c;
  SinCos(q, s, c);
  s *= j.axis_sign;
  auto rotate_columns = [&](int a, int b) {  // (col a, col b) <- (c a + s b, c b - s a)
    for (int i = 0; i < 3; ++i) {
      const V ma = M[3 * i + a], mb = M[3 * i + b];
      M[3 * i + a] = c * ma + s * mb;
      M[3 * i + b] = c * mb - s * ma;
    }
  };
  switch (j.axis_kind) {
    case 0: rotate_columns(1, 2); break;
    case 1: rotate_columns(2, 0); break;
    case 2: rotate_columns(0, 1); break;
    default: {
      // Rodrigues: Rot = c I + s [a]x + (1 - c) a a^T, then M <- M Rot.
      const Eigen::Vector3d& a = j.axis;
      const V t = 1.0 - c;
      V rot[9];
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k)
          rot[3 * r + k] = t * (a[r] * a[k]) + (r == k ? c : ISOWRENCH_V4_SPLAT(0.0));
      }
      rot[1] -= s * a[2];
      rot[2] += s * a[1];
      rot[3] += s * a[2];
      rot[5] -= s * a[0];
      rot[6] -= s * a[1];
      rot[7] += s * a[0];
      V out[9];
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k)
          out[3 * r + k] =
              M[3 * r] * rot[k] + M[3 * r + 1] * rot[3 + k] + M[3 * r + 2] * rot[6 + k];
      }
      std::memcpy(M, out, sizeof(out));
      break;
    }
  }
}

// Forward kinematics with the running frame (M, o) kept in registers: per joint its world axis
// and origin are stored, its frame only where a path point hangs on it.
ISOWRENCH_INLINE void ForwardKinematics(const FlatChain& d, LaneWorkspace::Impl& ws, V* M, V* o) {
  const int m = d.m;
  for (int k = 0; k < m; ++k) {
    const FastJoint& j = d.joints[k];
    if (k == 0) {
      for (int i = 0; i < 9; ++i) M[i] = ISOWRENCH_V4_SPLAT(j.origin_rotation(i / 3, i % 3));
      for (int i = 0; i < 3; ++i) o[i] = ISOWRENCH_V4_SPLAT(j.origin_translation[i]);
    } else {
      if (!j.translation_is_zero) {
        V step[3];
        MulConst(M, j.origin_translation, step);
        for (int i = 0; i < 3; ++i) o[i] += step[i];
      }
      if (!j.rotation_is_identity) {
        V R[9];
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) {
            R[3 * r + c] = M[3 * r] * j.origin_rotation(0, c) +
                           M[3 * r + 1] * j.origin_rotation(1, c) +
                           M[3 * r + 2] * j.origin_rotation(2, c);
          }
        }
        for (int i = 0; i < 9; ++i) M[i] = R[i];
      }
    }
    V* z = ws.axis[k];
    switch (j.axis_kind) {
      case 0:
        for (int i = 0; i < 3; ++i) z[i] = j.axis_sign * M[3 * i];
        break;
      case 1:
        for (int i = 0; i < 3; ++i) z[i] = j.axis_sign * M[3 * i + 1];
        break;
      case 2:
        for (int i = 0; i < 3; ++i) z[i] = j.axis_sign * M[3 * i + 2];
        break;
      default: MulConst(M, j.axis, z); break;
    }
    if (j.revolute) {
      RotateFrame(j, ws.q[k], M);
    } else {
      for (int i = 0; i < 3; ++i) o[i] += z[i] * ws.q[k];
    }
    for (int i = 0; i < 3; ++i) ws.origin[k][i] = o[i];
    if (ws.frame_needed[k]) {
      for (int i = 0; i < 9; ++i) ws.R[k][i] = M[i];
    }
  }
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneKinematics(const Model& model, LaneWorkspace& workspace,
                                         const double* const q[kLanes], int muscle,
                                         double activation) {
  const FlatChain& d = model.impl().flat;
  LaneWorkspace::Impl& ws = workspace.impl();
  const int m = d.m;
  // Postures (joint positions: on a coupled chain q_joint = f(q_c), lane by lane, with the
  // derivatives for the fold below), and whether every revolute angle is within the fast
  // sin/cos range.
  VI out_of_range = VI{0, 0, 0, 0};
  V dq_joint[kMaxDofs];
  for (int k = 0; k < m; ++k) {
    if (d.coupled) {
      const int c = d.coordinate[k];
      for (int l = 0; l < kLanes; ++l) {
        const double x = q[l][c];
        const bool identity = d.identity[k];
        ws.q[k][l] = identity ? x : d.coupling[k].Value(x);
        dq_joint[k][l] = identity ? 1.0 : d.coupling[k].Derivative(x);
      }
    } else {
      ws.q[k] = V{q[0][k], q[1][k], q[2][k], q[3][k]};
    }
    if (d.joints[k].revolute) {
      const V magnitude = (V)((VI)ws.q[k] & 0x7fffffffffffffff);
      out_of_range |= (magnitude < sincos::kMaxReduced) == 0;
    }
  }
  V R_last[9];
  V o[3];
  ForwardKinematics(d, ws, R_last, o);
  V endpoint[3];
  MulConst(R_last, d.endpoint, endpoint);
  for (int i = 0; i < 3; ++i) endpoint[i] += o[i];

  // Endpoint Jacobian in world axes, then in transducer axes.
  for (int k = 0; k < m; ++k) {
    const V* z = ws.axis[k];
    V* col = ws.J[k];
    if (d.joints[k].revolute) {
      V lever[3];
      for (int i = 0; i < 3; ++i) lever[i] = endpoint[i] - ws.origin[k][i];
      Cross(z, lever, col);
      for (int i = 0; i < 3; ++i) col[3 + i] = z[i];
    } else {
      for (int i = 0; i < 3; ++i) {
        col[i] = z[i];
        col[3 + i] = ISOWRENCH_V4_SPLAT(0.0);
      }
    }
  }
  if (!d.transducer_identity) {
    V R_W_T[9];
    if (d.transducer_in_world) {
      for (int i = 0; i < 9; ++i)
        R_W_T[i] = ISOWRENCH_V4_SPLAT(d.transducer_rotation(i / 3, i % 3));
    } else {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          R_W_T[3 * r + c] = R_last[3 * r] * d.transducer_rotation(0, c) +
                             R_last[3 * r + 1] * d.transducer_rotation(1, c) +
                             R_last[3 * r + 2] * d.transducer_rotation(2, c);
        }
      }
    }
    for (int k = 0; k < m; ++k) {
      V v[3], w[3];
      MulTransposed(R_W_T, ws.J[k], v);
      MulTransposed(R_W_T, ws.J[k] + 3, w);
      for (int i = 0; i < 3; ++i) {
        ws.J[k][i] = v[i];
        ws.J[k][3 + i] = w[i];
      }
    }
  }

  // Muscle: point positions, unit segment directions, pulls, then the backward sweep.
  const FastMuscle& mu = d.muscles[muscle];
  const int n = static_cast<int>(mu.points.size());
  for (int i = 0; i < n; ++i) {
    const FastPathPoint& p = mu.points[i];
    if (p.frame < 0) {
      for (int c = 0; c < 3; ++c) ws.points[i][c] = ISOWRENCH_V4_SPLAT(p.position[c]);
    } else {
      MulConst(ws.R[p.frame], p.position, ws.points[i]);
      for (int c = 0; c < 3; ++c) ws.points[i][c] += ws.origin[p.frame][c];
    }
  }
  VI coincident = VI{0, 0, 0, 0};
  V u_before[3] = {ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0)};
  for (int i = 1; i < n; ++i) {
    V segment[3];
    for (int c = 0; c < 3; ++c) segment[c] = ws.points[i][c] - ws.points[i - 1][c];
    V length;
    Sqrt(segment[0] * segment[0] + segment[1] * segment[1] + segment[2] * segment[2], length);
    coincident |= (length >= kFastMinSegmentLength) == 0;
    for (int c = 0; c < 3; ++c) {
      const V u = segment[c] / length;
      ws.pulls[i - 1][c] = u_before[c] - u;
      u_before[c] = u;
    }
  }
  for (int c = 0; c < 3; ++c) ws.pulls[n - 1][c] = u_before[c];
  V pull_sum[3] = {ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0)};
  V moment_sum[3] = {ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0)};
  const int sweep_count = static_cast<int>(mu.sweep_order.size());
  int next = 0;
  const V minus_force = ISOWRENCH_V4_SPLAT(-activation * mu.max_force);
  for (int k = m - 1; k >= 0; --k) {
    while (next < sweep_count && mu.points[mu.sweep_order[next]].frame == k) {
      const int i = mu.sweep_order[next++];
      V moment[3];
      Cross(ws.points[i], ws.pulls[i], moment);
      for (int c = 0; c < 3; ++c) {
        pull_sum[c] += ws.pulls[i][c];
        moment_sum[c] += moment[c];
      }
    }
    const V* z = ws.axis[k];
    V dL;
    if (d.joints[k].revolute) {
      V arm[3];
      Cross(ws.origin[k], pull_sum, arm);
      dL = z[0] * (moment_sum[0] - arm[0]) + z[1] * (moment_sum[1] - arm[1]) +
           z[2] * (moment_sum[2] - arm[2]);
    } else {
      dL = z[0] * pull_sum[0] + z[1] * pull_sum[1] + z[2] * pull_sum[2];
    }
    ws.tau[k] = minus_force * dL;
  }
  if (d.coupled) {  // joint columns into coordinate columns (Fold in fast.cpp)
    V J[kMaxDofs][6];
    V tau[kMaxDofs];
    for (int c = 0; c < d.n; ++c) {
      tau[c] = ISOWRENCH_V4_SPLAT(0.0);
      for (int r = 0; r < 6; ++r) J[c][r] = ISOWRENCH_V4_SPLAT(0.0);
    }
    for (int k = 0; k < m; ++k) {
      const int c = d.coordinate[k];
      for (int r = 0; r < 6; ++r) J[c][r] += dq_joint[k] * ws.J[k][r];
      tau[c] += dq_joint[k] * ws.tau[k];
    }
    for (int c = 0; c < d.n; ++c) {
      for (int r = 0; r < 6; ++r) ws.J[c][r] = J[c][r];
      ws.tau[c] = tau[c];
    }
  }
  return Bits(coincident | out_of_range);
}

ISOWRENCH_CLONES void LaneBroadcast(const Data& scalar, LaneWorkspace& workspace) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const Data::Impl& s = scalar.impl();
  for (int k = 0; k < ws.m; ++k) {
    for (int r = 0; r < 6; ++r) ws.J[k][r] = ISOWRENCH_V4_SPLAT(s.J(r, k));
    ws.tau[k] = ISOWRENCH_V4_SPLAT(s.tau[k]);
  }
}

namespace {

// SolveKernel of fast.cpp on lanes: K = J^T S_t J + S_p (lower triangle), Cholesky with the
// same pivot rule, two triangular solves, W = S_t J dtheta. Returns the undecided lanes' mask.
template <int N>
ISOWRENCH_INLINE void SolveLanesKernel(LaneWorkspace::Impl& ws, int m_runtime, const V* s_t,
                                       const V* s_p, const SolveOptions& options, V* wrench,
                                       VI& undecided) {
  constexpr int S = kMaxDofs;
  const int m = N > 0 ? N : std::min(m_runtime, S);
  V* K = ws.K;
  V* U = ws.U;
  V max_diag = ISOWRENCH_V4_SPLAT(0.0);
  ISOWRENCH_UNROLL
  for (int i = 0; i < m; ++i) {
    V sj[6];
    ISOWRENCH_UNROLL
    for (int r = 0; r < 6; ++r) sj[r] = s_t[r] * ws.J[i][r];
    ISOWRENCH_UNROLL
    for (int j = 0; j <= i; ++j) {
      V sum = sj[0] * ws.J[j][0];
      ISOWRENCH_UNROLL
      for (int r = 1; r < 6; ++r) sum += sj[r] * ws.J[j][r];
      K[i * S + j] = sum;
    }
    K[i * S + i] += s_p[i];
    max_diag = K[i * S + i] > max_diag ? K[i * S + i] : max_diag;
  }
  const V pivot_floor = options.cholesky_pivot_tolerance * max_diag;
  undecided = (max_diag > 0.0) == 0;
  V inv_diag[S];
  ISOWRENCH_UNROLL
  for (int j = 0; j < m; ++j) {
    V d = K[j * S + j];
    ISOWRENCH_UNROLL
    for (int k = 0; k < j; ++k) d -= U[k * S + j] * U[k * S + j];
    undecided |= (d > pivot_floor) == 0;
    V l;
    Sqrt(d, l);
    const V inv = 1.0 / l;
    inv_diag[j] = inv;
    ISOWRENCH_UNROLL
    for (int i = j + 1; i < m; ++i) {
      V v = K[i * S + j];
      ISOWRENCH_UNROLL
      for (int k = 0; k < j; ++k) v -= U[k * S + i] * U[k * S + j];
      U[j * S + i] = v * inv;
    }
  }
  V y[S];
  V* x = ws.x;
  SolveWithFactor<N>(m, U, inv_diag, ws.tau, y, x);
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    V v = ws.J[0][r] * x[0];
    ISOWRENCH_UNROLL
    for (int j = 1; j < m; ++j) v += ws.J[j][r] * x[j];
    wrench[r] = s_t[r] * v;
    undecided |= (wrench[r] - wrench[r]) != 0.0;  // inf or NaN
  }
}

// Returns the undecided lanes' bitmask.
ISOWRENCH_INLINE unsigned SolveLanesDispatch(LaneWorkspace::Impl& ws, const V* s_t, const V* s_p,
                                             const SolveOptions& options, V* wrench) {
  VI undecided;
  switch (ws.m) {
    case 1: SolveLanesKernel<1>(ws, 1, s_t, s_p, options, wrench, undecided); break;
    case 2: SolveLanesKernel<2>(ws, 2, s_t, s_p, options, wrench, undecided); break;
    case 3: SolveLanesKernel<3>(ws, 3, s_t, s_p, options, wrench, undecided); break;
    case 4: SolveLanesKernel<4>(ws, 4, s_t, s_p, options, wrench, undecided); break;
    case 5: SolveLanesKernel<5>(ws, 5, s_t, s_p, options, wrench, undecided); break;
    case 6: SolveLanesKernel<6>(ws, 6, s_t, s_p, options, wrench, undecided); break;
    case 7: SolveLanesKernel<7>(ws, 7, s_t, s_p, options, wrench, undecided); break;
    case 8: SolveLanesKernel<8>(ws, 8, s_t, s_p, options, wrench, undecided); break;
    default: SolveLanesKernel<0>(ws, ws.m, s_t, s_p, options, wrench, undecided); break;
  }
  return Bits(undecided);
}

}  // namespace

ISOWRENCH_CLONES unsigned LaneSolve(const Model& model, LaneWorkspace& workspace,
                                    const StiffnessSet* const sets[kLanes],
                                    const SolveOptions& options, WrenchResult* const out[kLanes]) {
  LaneWorkspace::Impl& ws = workspace.impl();
  const int m = model.dof_count();
  // Locked coordinates: the scalar path's SolveLocked decides every lane.
  if (model.impl().flat.any_locked) return (1u << kLanes) - 1;
  V s_t[6];
  V s_p[kMaxDofs];
  if (sets[0] == sets[1] && sets[0] == sets[2] && sets[0] == sets[3]) {  // four postures, one set
    for (int r = 0; r < 6; ++r) s_t[r] = ISOWRENCH_V4_SPLAT(sets[0]->s_t[r]);
    for (int i = 0; i < m; ++i) s_p[i] = ISOWRENCH_V4_SPLAT(sets[0]->s_p[i]);
  } else {
    for (int r = 0; r < 6; ++r)
      s_t[r] = V{sets[0]->s_t[r], sets[1]->s_t[r], sets[2]->s_t[r], sets[3]->s_t[r]};
    for (int i = 0; i < m; ++i)
      s_p[i] = V{sets[0]->s_p[i], sets[1]->s_p[i], sets[2]->s_p[i], sets[3]->s_p[i]};
  }
  V wrench[6];
  const unsigned undecided = SolveLanesDispatch(ws, s_t, s_p, options, wrench);
  for (int l = 0; l < kLanes; ++l) {
    if (undecided & (1u << l)) continue;
    WrenchResult& w = *out[l];
    for (int r = 0; r < 6; ++r) w.wrench[r] = wrench[r][l];
    w.status = StaticsStatus::kOk;
    w.self_motion_count = 0;
  }
  return undecided;
}

}  // namespace isowrench
