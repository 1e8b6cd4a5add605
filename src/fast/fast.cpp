// The fast path: a flat copy of the chain, allocation-free kinematics and statics.
//
// Kinematics (per movable joint k, parent frame (R, o), folded fixed transform (R0, p0)):
//   joint origin  j_k = o + R p0,   M = R R0,   world axis z_k = M a_k,
//   revolute:  R_k = M Rot(a_k, q_k), o_k = j_k;   prismatic: R_k = M, o_k = j_k + z_k q_k.
// Endpoint Jacobian columns (KDL's, reference point p_E, world axes):
//   revolute [z_k x (p_E - o_k); z_k],  prismatic [z_k; 0].
// Muscle: with unit segment directions u_i, dL/dtheta = sum_points Jp(x_i)^T g_i where
// g_i = u_{i-1} - u_i is the "pull" at point i (u_{-1} = u_n = 0). Summing the pulls and their
// moments from the distal end (a backward sweep over joints) gives, per joint k,
//   revolute  dL/dtheta_k = z_k . (sum x_i x g_i - o_k x sum g_i),  prismatic z_k . sum g_i,
// over the points distal to joint k: O(m + points) instead of one point Jacobian per point.

#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>

#include "fast/fast_impl.hpp"
#include "fast/simd.hpp"
#include "isowrench/error.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace {

// sin and cos of one angle, to within an ulp or two, in about 50 instructions instead of the
// ~120 of libm's sincos (which also handles huge arguments exactly): sincos::Kernel (simd.hpp)
// and the quadrant. Angles beyond sincos::kMaxReduced fall back to std::sin/std::cos.
ISOWRENCH_INLINE void SinCos(double x, double* sin_x, double* cos_x) {
  if (!(std::abs(x) < sincos::kMaxReduced)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
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
  *sin_x = sign_sin * (swap ? cos_r : sin_r);
  *cos_x = sign_cos * (swap ? sin_r : cos_r);
}

// M <- M R0 for 3x3 column-major arrays (R0 a fixed origin rotation).
ISOWRENCH_INLINE void MultiplyRotation(double* M, const double* R0) {
  double P[9];
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) {
      P[3 * c + r] = M[r] * R0[3 * c] + M[3 + r] * R0[3 * c + 1] + M[6 + r] * R0[3 * c + 2];
    }
  }
  for (int i = 0; i < 9; ++i) M[i] = P[i];
}

// World axis z = sign * column K of M, then (revolute) M <- M Rot(e_K, q) given c = cos q and
// s = sign * sin q; a prismatic joint passes turn = false.
template <int K>
ISOWRENCH_INLINE void AxisAndTurn(double* M, double sign, double c, double s, double* z,
                                  bool turn = true) {
  z[0] = sign * M[3 * K];
  z[1] = sign * M[3 * K + 1];
  z[2] = sign * M[3 * K + 2];
  if (!turn) return;
  constexpr int A = 3 * ((K + 1) % 3), B = 3 * ((K + 2) % 3);  // the two columns that turn
  const double a0 = M[A], a1 = M[A + 1], a2 = M[A + 2];
  const double b0 = M[B], b1 = M[B + 1], b2 = M[B + 2];
  M[A] = c * a0 + s * b0;
  M[A + 1] = c * a1 + s * b1;
  M[A + 2] = c * a2 + s * b2;
  M[B] = c * b0 - s * a0;
  M[B + 1] = c * b1 - s * a1;
  M[B + 2] = c * b2 - s * a2;
}

// The same for a general unit axis, out of line (no shipped chain has one); M goes through a
// copy so that the caller's frame never has its address taken and stays in registers.
ISOWRENCH_NOINLINE void GeneralAxisAndTurnOutOfLine(Eigen::Matrix3d& M, const FastJoint& j,
                                                    double q, double* z, bool turn) {
  Eigen::Map<Eigen::Vector3d>(z).noalias() = M * j.axis;
  if (turn) {
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(q, j.axis).toRotationMatrix();
    M = (M * rot).eval();
  }
}
ISOWRENCH_INLINE void GeneralAxisAndTurn(double* M, const FastJoint& j, double q, double* z,
                                         bool turn) {
  Eigen::Matrix3d copy;
  for (int i = 0; i < 9; ++i) copy.data()[i] = M[i];
  GeneralAxisAndTurnOutOfLine(copy, j, q, z, turn);
  for (int i = 0; i < 9; ++i) M[i] = copy.data()[i];
}

// The eigen-solve used when the Cholesky pivots say K is (nearly) singular: the same rank and
// excitation decisions as SolveStatics, on the workspace's fixed-size buffers.
WrenchResult SolveByEigen(Data::Impl& ws, int m, const double* J, const double* s_t,
                          const double* tau, const SolveOptions& options) {
  WrenchResult out;
  JointMatrix& K = ws.K_full;
  K.resize(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) K(i, j) = K(j, i) = ws.K[j * kMaxDofs + i];  // upper triangle
  }
  ws.eigen.compute(K);
  const auto& lambda = ws.eigen.eigenvalues();
  const auto& V = ws.eigen.eigenvectors();
  const double lambda_max = std::max(lambda[m - 1], 0.0);
  const double threshold = options.rank_tolerance * lambda_max;
  double tau_norm2 = 0.0;
  for (int i = 0; i < m; ++i) tau_norm2 += tau[i] * tau[i];
  const double tau_norm = std::sqrt(tau_norm2);
  int nulls = 0;
  for (int i = 0; i < m; ++i) {
    if (lambda[i] <= threshold || lambda_max == 0.0) ++nulls;
  }
  ws.dtheta.setZero(m);
  ws.self_motion.resize(m, nulls);
  bool excited = false;
  int c = 0;
  for (int i = 0; i < m; ++i) {
    double v_tau = 0.0;
    for (int r = 0; r < m; ++r) v_tau += V(r, i) * tau[r];
    if (lambda[i] <= threshold || lambda_max == 0.0) {
      // Sign convention of StaticsResult::self_motion: largest-magnitude entry positive.
      Eigen::Index largest = 0;
      V.col(i).cwiseAbs().maxCoeff(&largest);
      const double sign = V(largest, i) < 0 ? -1.0 : 1.0;
      ws.self_motion.col(c++) = sign * V.col(i);
      if (std::abs(v_tau) > options.excitation_tolerance * tau_norm) excited = true;
    } else {
      ws.dtheta += V.col(i) * (v_tau / lambda[i]);
    }
  }
  out.self_motion_count = nulls;
  if (excited) {
    out.status = StaticsStatus::kSelfMotion;
    ws.dtheta.setZero(m);
    return out;
  }
  for (int r = 0; r < 6; ++r) {
    double v = 0.0;
    for (int j = 0; j < m; ++j) v += J[j * 6 + r] * ws.dtheta[j];
    out.wrench[r] = s_t[r] * v;
  }
  out.status = nulls == 0 ? StaticsStatus::kOk : StaticsStatus::kSelfMotionHeld;
  return out;
}

// Inputs of a solve are checked, not trusted: negative or non-finite values give kInvalidInput.
// Branch-free so it vectorises: 0 * v is 0 for finite v and NaN for inf/NaN, so the sum of
// those is 0 exactly when every entry is finite; the minimum catches negative stiffness.
ISOWRENCH_INLINE bool ValidSolveInput(int m, const double* s_t, const double* s_p,
                                      const double* tau) {
  double nonfinite = 0.0;
  double lowest = 0.0;
  for (int r = 0; r < 6; ++r) {
    nonfinite += 0.0 * s_t[r];
    lowest = std::min(lowest, s_t[r]);
  }
  for (int i = 0; i < m; ++i) {
    nonfinite += 0.0 * s_p[i] + 0.0 * tau[i];
    lowest = std::min(lowest, s_p[i]);
  }
  return nonfinite == 0.0 && lowest >= 0.0;
}

WrenchResult Invalid(Data::Impl& ws) {
  ws.dtheta.setZero(ws.m);
  ws.self_motion.resize(ws.m, 0);
  return WrenchResult{};
}

// Every solve keeps K = J^T S_t J + S_p in ws.K as its upper triangle by rows (K_ij, j >= i, at
// ws.K[i * kMaxDofs + j]): the eigen fallback reads it from there. The factor is kept as
// U = L^T (K = U^T U), row j of U at U[j * kMaxDofs + k], k >= j; both kernels below form
// the same products and sums in the same order (up to the compiler's fusing of multiply-adds):
// K_ij = sum_r (s_r J_rj) J_ri, the pivot d_j = K_jj - sum_{k<j} U_kj^2 and, for i > j,
// U_ji = (K_ji - sum_{k<j} U_kj U_ki) / sqrt(d_j).

// Forward and back substitution with U (only its strict upper triangle and the reciprocal
// diagonal are read), then W = S_t J dtheta. N > 0 fixes m at compile time (loops unroll).
template <int N>
ISOWRENCH_INLINE WrenchResult Substitute(Data::Impl& ws, int m, const double* U,
                                         const double* inv_diag, const double* J, const double* s_t,
                                         const double* tau) {
  constexpr int S = kMaxDofs;
  double y[S];
  ws.dtheta.resize(m);
  double* x = ws.dtheta.data();
  SolveWithFactor<N>(m, U, inv_diag, tau, y, x);
  WrenchResult out;
  if (N > 0) {
    // W on 4-double vectors: rows 0-3 and rows 2-5 of each column of J (rows 2 and 3 twice),
    // the same sums in the same order as below.
    V4 head = ISOWRENCH_V4_SPLAT(0.0), tail = ISOWRENCH_V4_SPLAT(0.0);
    ISOWRENCH_UNROLL
    for (int j = 0; j < m; ++j) {
      V4 c0, c1;
      ISOWRENCH_V4_LOAD(c0, J + 6 * j);
      ISOWRENCH_V4_LOAD(c1, J + 6 * j + 2);
      const V4 xj = ISOWRENCH_V4_SPLAT(x[j]);
      head += c0 * xj;
      tail += c1 * xj;
    }
    V4 s0, s1;
    ISOWRENCH_V4_LOAD(s0, s_t);
    ISOWRENCH_V4_LOAD(s1, s_t + 2);
    head *= s0;
    tail *= s1;
    ISOWRENCH_V4_STORE(out.wrench.data(), head);
    ISOWRENCH_V4_STORE(out.wrench.data() + 2, tail);
  } else {
    ISOWRENCH_UNROLL
    for (int r = 0; r < 6; ++r) {
      double v = 0.0;
      ISOWRENCH_UNROLL
      for (int j = 0; j < m; ++j) v += J[j * 6 + r] * x[j];
      out.wrench[r] = s_t[r] * v;
    }
  }
  out.status = StaticsStatus::kOk;
  ws.self_motion.resize(m, 0);
  return out;
}

// K, Cholesky, the solves, on scalars: any m (N = 0: the runtime m).
template <int N>
ISOWRENCH_INLINE WrenchResult SolveKernel(Data::Impl& ws, int m_runtime, const double* J,
                                          const double* s_t, const double* s_p, const double* tau,
                                          const SolveOptions& options) {
  constexpr int S = kMaxDofs;
  const int m = N > 0 ? N : std::min(m_runtime, S);  // workspaces never exceed S
  if (!ValidSolveInput(m, s_t, s_p, tau)) return Invalid(ws);
  double* K = ws.K;
  double max_diag = 0.0;
  ISOWRENCH_UNROLL
  for (int i = 0; i < m; ++i) {
    ISOWRENCH_UNROLL
    for (int j = i; j < m; ++j) {
      double sum = 0.0;
      ISOWRENCH_UNROLL
      for (int r = 0; r < 6; ++r) sum += (s_t[r] * J[j * 6 + r]) * J[i * 6 + r];
      K[i * S + j] = sum;
    }
    K[i * S + i] += s_p[i];
    max_diag = std::max(max_diag, K[i * S + i]);
  }
  // Cholesky K = U^T U (left-looking), accepted only with every pivot clearly positive.
  const double pivot_floor = options.cholesky_pivot_tolerance * max_diag;
  double U[S * S];
  double inv_diag[S];
  if (!(max_diag > 0.0)) return SolveByEigen(ws, m, J, s_t, tau, options);
  ISOWRENCH_UNROLL
  for (int j = 0; j < m; ++j) {
    double d = K[j * S + j];
    ISOWRENCH_UNROLL
    for (int k = 0; k < j; ++k) d -= U[k * S + j] * U[k * S + j];
    if (!(d > pivot_floor)) return SolveByEigen(ws, m, J, s_t, tau, options);
    const double inv = 1.0 / std::sqrt(d);
    inv_diag[j] = inv;
    ISOWRENCH_UNROLL
    for (int i = j + 1; i < m; ++i) {
      double v = K[j * S + i];
      ISOWRENCH_UNROLL
      for (int k = 0; k < j; ++k) v -= U[k * S + i] * U[k * S + j];
      U[j * S + i] = v * inv;
    }
  }
  return Substitute<N>(ws, m, U, inv_diag, J, s_t, tau);
}

// The kernel on V4, for 1 <= N <= 10 (the dispatch below). K is built by rows,
// K(i, :) = sum_r J_ri (s_r J(r, :)) from the rows of J (ws.J_rows), and factored right-looking
// (row j of U, then the rank-1 update of the rows below it), both in blocks of 4 columns of
// the upper triangle; the entries of a block left of the diagonal and beyond m are computed
// too (from the zero columns of J_rows beyond m) and ignored.

// Branch-free check of the solve inputs (as ValidSolveInput), m = N entries of s_p and tau.
template <int N>
ISOWRENCH_INLINE bool ValidSolveInputV4(const double* s_t, const double* s_p, const double* tau) {
  if (N < 4) return ValidSolveInput(N, s_t, s_p, tau);
  const V4 zero = ISOWRENCH_V4_SPLAT(0.0);
  // Blocks of 4 covering [0, N), the last one overlapping its neighbour when 4 does not divide N.
  V4 st0, st1;
  ISOWRENCH_V4_LOAD(st0, s_t);
  ISOWRENCH_V4_LOAD(st1, s_t + 2);
  V4 nonfinite = st0 * zero + st1 * zero;
  V4 lowest = st0 < st1 ? st0 : st1;
  ISOWRENCH_UNROLL
  for (int b = 0; b < (N + 3) / 4; ++b) {
    const int at = std::min(4 * b, N - 4);
    V4 p, t;
    ISOWRENCH_V4_LOAD(p, s_p + at);
    ISOWRENCH_V4_LOAD(t, tau + at);
    nonfinite += p * zero + t * zero;
    lowest = lowest < p ? lowest : p;
  }
  const double nf = (nonfinite[0] + nonfinite[1]) + (nonfinite[2] + nonfinite[3]);
  const double lo = std::min(std::min(lowest[0], lowest[1]), std::min(lowest[2], lowest[3]));
  return nf == 0.0 && lo >= 0.0;
}

template <int N>
ISOWRENCH_INLINE WrenchResult SolveKernelV4(Data::Impl& ws, const double* J, const double* s_t,
                                            const double* s_p, const double* tau,
                                            const SolveOptions& options) {
  static_assert(N >= 1 && 4 * ((N + 3) / 4) <= kMaxDofs, "blocks within a row of J_rows");
  constexpr int S = kMaxDofs;
  constexpr int B = (N + 3) / 4;  // blocks of 4 columns
  if (!ValidSolveInputV4<N>(s_t, s_p, tau)) return Invalid(ws);
  const double* Jr = ws.J_rows;
  V4 Jv[6][B], sJ[6][B];
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    const V4 s = ISOWRENCH_V4_SPLAT(s_t[r]);
    ISOWRENCH_UNROLL
    for (int b = 0; b < B; ++b) {
      ISOWRENCH_V4_LOAD(Jv[r][b], Jr + r * S + 4 * b);
      sJ[r][b] = s * Jv[r][b];
    }
  }
  // A: the rows of K (blocks b >= i / 4), updated in place into the trailing matrix.
  V4 A[N][B];
  double* K = ws.K;
  double max_diag = 0.0;
  ISOWRENCH_UNROLL
  for (int i = 0; i < N; ++i) {
    ISOWRENCH_UNROLL
    for (int b = i / 4; b < B; ++b) {
      V4 acc = ISOWRENCH_V4_SPLAT(Jr[i]) * sJ[0][b];
      ISOWRENCH_UNROLL
      for (int r = 1; r < 6; ++r) acc += ISOWRENCH_V4_SPLAT(Jr[r * S + i]) * sJ[r][b];
      A[i][b] = acc;
    }
    V4 diagonal = ISOWRENCH_V4_SPLAT(0.0);
    diagonal[i % 4] = s_p[i];
    A[i][i / 4] += diagonal;
    ISOWRENCH_UNROLL
    for (int b = i / 4; b < B; ++b) ISOWRENCH_V4_STORE(K + i * S + 4 * b, A[i][b]);
    max_diag = std::max(max_diag, K[i * S + i]);
  }
  const double pivot_floor = options.cholesky_pivot_tolerance * max_diag;
  if (!(max_diag > 0.0)) return SolveByEigen(ws, N, J, s_t, tau, options);
  double U[N * S];
  double inv_diag[N];
  ISOWRENCH_UNROLL
  for (int j = 0; j < N; ++j) {
    const double d = A[j][j / 4][j % 4];
    if (!(d > pivot_floor)) return SolveByEigen(ws, N, J, s_t, tau, options);
    const double inv = 1.0 / std::sqrt(d);
    inv_diag[j] = inv;
    V4 u[B];
    ISOWRENCH_UNROLL
    for (int b = j / 4; b < B; ++b) {
      u[b] = A[j][b] * ISOWRENCH_V4_SPLAT(inv);
      ISOWRENCH_V4_STORE(U + j * S + 4 * b, u[b]);
    }
    ISOWRENCH_UNROLL
    for (int i = j + 1; i < N; ++i) {
      const V4 u_i = ISOWRENCH_V4_SPLAT(u[i / 4][i % 4]);
      ISOWRENCH_UNROLL
      for (int b = i / 4; b < B; ++b) A[i][b] -= u_i * u[b];
    }
  }
  return Substitute<N>(ws, N, U, inv_diag, J, s_t, tau);
}

ISOWRENCH_CLONES WrenchResult SolveDispatch(Data::Impl& ws, const double* J, const double* s_t,
                                            const double* s_p, const double* tau,
                                            const SolveOptions& options) {
  switch (ws.m) {
    case 1: return SolveKernelV4<1>(ws, J, s_t, s_p, tau, options);
    case 2: return SolveKernelV4<2>(ws, J, s_t, s_p, tau, options);
    case 3: return SolveKernelV4<3>(ws, J, s_t, s_p, tau, options);
    case 4: return SolveKernelV4<4>(ws, J, s_t, s_p, tau, options);
    case 5: return SolveKernelV4<5>(ws, J, s_t, s_p, tau, options);
    case 6: return SolveKernelV4<6>(ws, J, s_t, s_p, tau, options);
    case 7: return SolveKernelV4<7>(ws, J, s_t, s_p, tau, options);
    case 8: return SolveKernelV4<8>(ws, J, s_t, s_p, tau, options);
    case 9: return SolveKernelV4<9>(ws, J, s_t, s_p, tau, options);
    case 10: return SolveKernelV4<10>(ws, J, s_t, s_p, tau, options);
    default: return SolveKernel<0>(ws, ws.m, J, s_t, s_p, tau, options);
  }
}

}  // namespace

std::string StatusMessage(const WrenchResult& result) {
  const std::string count = std::to_string(result.self_motion_count) +
                            (result.self_motion_count == 1 ? " direction" : " directions");
  switch (result.status) {
    case StaticsStatus::kOk: return "ok: K = J^T S_t J + S_p is positive definite; W unique";
    case StaticsStatus::kSelfMotionHeld:
      return "self-motion (not excited): null(K) has " + count +
             " that tau does not drive; W unique (pseudo-inverse solve)";
    case StaticsStatus::kSelfMotion:
      return "self-motion: tau drives " + count +
             " of null(K); no equilibrium, W not defined (zeros)";
    case StaticsStatus::kInvalidInput: break;
  }
  return "invalid input: a stiffness or torque entry is negative or not finite, a size does not "
         "match, or two consecutive muscle path points coincide at this posture; W not computed "
         "(zeros)";
}

// ---- Data --------------------------------------------------------------------------

Data::Impl::Impl(int dofs) : m(dofs), eigen(dofs) {
  J.setZero(6, m);
  dL.setZero(m);
  tau.setZero(m);
  dtheta.setZero(m);
  K_full.setZero(m, m);
  self_motion.resize(m, 0);
  for (double& v : K) v = 0.0;
  for (double& v : J_rows) v = 0.0;
}

Data::Data(const Model& model) : impl_(std::make_unique<Impl>(model.dof_count())) {}

Data::Data(int dof_count) {
  if (dof_count < 1 || dof_count > kMaxDofs) {
    throw Error("Data: dof count " + std::to_string(dof_count) + " is not in [1, " +
                std::to_string(kMaxDofs) + "]");
  }
  impl_ = std::make_unique<Impl>(dof_count);
}

Data::~Data() = default;
Data::Data(Data&&) noexcept = default;
Data& Data::operator=(Data&&) noexcept = default;

const JacobianBuffer& Data::jacobian() const { return impl_->J; }
const JointVector& Data::tau() const { return impl_->tau; }
const JointVector& Data::muscle_length_gradient() const { return impl_->dL; }
double Data::muscle_length() const { return impl_->length; }
const Eigen::Vector3d& Data::endpoint_position() const { return impl_->endpoint; }
const Eigen::Matrix3d& Data::transducer_rotation() const { return impl_->R_W_T; }
const JointVector& Data::dtheta() const { return impl_->dtheta; }
const JointMatrix& Data::self_motion() const { return impl_->self_motion; }

// ---- Evaluation -----------------------------------------------------------------------------

namespace {

// Column k of the endpoint Jacobian (reference point p_E, world axes turned into transducer
// axes by T = R_W_T unless `rotate` is false), stored column-major in J and row-major in J_rows.
ISOWRENCH_INLINE void JacobianColumn(Data::Impl& ws, int k, bool revolute, const double* pe,
                                     bool rotate, const double* T) {
  constexpr int S = kMaxDofs;
  const double* z = ws.axis[k].data();
  double v[3], w[3];
  if (revolute) {
    const double* ok = ws.origin[k].data();
    const double d0 = pe[0] - ok[0], d1 = pe[1] - ok[1], d2 = pe[2] - ok[2];
    v[0] = z[1] * d2 - z[2] * d1;
    v[1] = z[2] * d0 - z[0] * d2;
    v[2] = z[0] * d1 - z[1] * d0;
    w[0] = z[0];
    w[1] = z[1];
    w[2] = z[2];
  } else {
    v[0] = z[0];
    v[1] = z[1];
    v[2] = z[2];
    w[0] = w[1] = w[2] = 0.0;
  }
  if (rotate) {  // R_W_T^T v, R_W_T^T w
    const double v0 = v[0], v1 = v[1], v2 = v[2], w0 = w[0], w1 = w[1], w2 = w[2];
    for (int i = 0; i < 3; ++i) {
      v[i] = T[3 * i] * v0 + T[3 * i + 1] * v1 + T[3 * i + 2] * v2;
      w[i] = T[3 * i] * w0 + T[3 * i + 1] * w1 + T[3 * i + 2] * w2;
    }
  }
  double* col = ws.J.data() + 6 * k;
  double* Jr = ws.J_rows;
  for (int r = 0; r < 3; ++r) {
    col[r] = v[r];
    col[r + 3] = w[r];
    Jr[r * S + k] = v[r];
    Jr[(r + 3) * S + k] = w[r];
  }
}

}  // namespace

namespace {

const FastMuscle kNoMuscle{};  // the muscle of a kinematics call without one

// Coupled chains: q_joint_k = f_k(q[c_k]) and its derivative for every movable joint.
ISOWRENCH_NOINLINE void Couple(const FlatChain& d, Data::Impl& ws, const double* q) {
  for (int k = 0; k < d.m; ++k) {
    const double x = q[d.coordinate[k]];
    if (d.identity[k]) {
      ws.q_joint[k] = x;
      ws.dq_joint[k] = 1.0;
    } else {
      ws.q_joint[k] = d.coupling[k].Value(x);
      ws.dq_joint[k] = d.coupling[k].Derivative(x);
    }
  }
}

// Coupled chains: the joint columns of J and dL/dq (m of them) folded into coordinate columns
// (n), J[:, c] = sum_{k: c_k = c} J_joint[:, k] dq_joint_k/dq_c, the same for dL/dq; tau =
// minus_force dL/dq. J_rows follows J and stays zero beyond n.
ISOWRENCH_NOINLINE void Fold(const FlatChain& d, Data::Impl& ws, double minus_force) {
  constexpr int S = kMaxDofs;
  double J[6 * S] = {};
  double dL[S] = {};
  const double* joint_J = ws.J.data();
  for (int k = 0; k < d.m; ++k) {
    const int c = d.coordinate[k];
    const double f = ws.dq_joint[k];
    for (int r = 0; r < 6; ++r) J[6 * c + r] += f * joint_J[6 * k + r];
    dL[c] += f * ws.dL[k];
  }
  ws.J.resize(6, d.n);
  ws.dL.resize(d.n);
  ws.tau.resize(d.n);
  for (int c = 0; c < S; ++c) {
    for (int r = 0; r < 6; ++r) {
      const double v = c < d.n ? J[6 * c + r] : 0.0;
      ws.J_rows[r * S + c] = v;
      if (c < d.n) ws.J(r, c) = v;
    }
    if (c < d.n) {
      ws.dL[c] = dL[c];
      ws.tau[c] = minus_force * dL[c];
    }
  }
}

// The kinematics kernel. kFrames: also store each movable joint's world rotation in ws.frames,
// accept muscle < 0 (no muscle) and world_axes (J in world axes); the evaluation path
// instantiates it with kFrames = false, where those are compile-time off. kDynamic: the muscle
// has moving or conditional points (FastMuscle::dynamic, src/fast/path_points.cpp); other
// muscles run the kDynamic = false instantiation, where those steps are compiled out.
template <bool kFrames, bool kDynamic>
ISOWRENCH_INLINE bool KinematicsKernel(const FlatChain& d, Data::Impl& ws, const double* qv,
                                       int muscle, double activation, bool world_axes) {
  const int m = d.m;
  assert(ws.m == d.n);
  assert(muscle < static_cast<int>(d.muscles.size()) && (kFrames || muscle >= 0));
  const FastMuscle& mu = (kFrames && muscle < 0) ? kNoMuscle : d.muscles[muscle];
  // Moving and conditional points: positions in their frames (ws.local) and the active points.
  constexpr bool dynamic = kDynamic;
  if (dynamic) PreparePathPoints(mu, qv, ws);
  if (d.coupled) {
    Couple(d, ws, qv);
    qv = ws.q_joint;
  }
  const FastJoint* joints = d.joints.data();
  const int n = static_cast<int>(mu.points.size());
  const FastPathPoint* pts = mu.points.data();
  const int* order = mu.sweep_order.data();  // points by decreasing frame, ground ones left out
  const int sweep_count = static_cast<int>(mu.sweep_order.size());

  // Path points on ground are fixed in world; the others are placed as soon as their frame is
  // known (walking sweep_order from its end: increasing frames), so that no frame is stored.
  for (int i = 0; i < n; ++i) {
    if (pts[i].frame < 0) {
      ws.points[i] = dynamic ? ws.local[i] : pts[i].position;
      if (dynamic) ws.point_rotation[i].setIdentity();
    }
  }
  int next_point = sweep_count - 1;

  // Forward kinematics along the chain. The current frame lives in locals (registers): rotation
  // M column-major (M[3 c + r]) and origin o; it starts as the world frame.
  double M[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  double o[3] = {0.0, 0.0, 0.0};
  for (int k = 0; k < m; ++k) {
    const FastJoint& j = joints[k];
    if (!j.translation_is_zero) {  // joint origin o + M p0
      const double* t = j.origin_translation.data();
      const double t0 = t[0], t1 = t[1], t2 = t[2];
      const double p0 = M[0] * t0 + M[3] * t1 + M[6] * t2;
      const double p1 = M[1] * t0 + M[4] * t1 + M[7] * t2;
      const double p2 = M[2] * t0 + M[5] * t1 + M[8] * t2;
      o[0] = o[0] + p0;
      o[1] = o[1] + p1;
      o[2] = o[2] + p2;
    }
    if (!j.rotation_is_identity) MultiplyRotation(M, j.origin_rotation.data());
    double* z = ws.axis[k].data();
    const double qk = qv[k];
    if (j.revolute) {
      double c, s;
      SinCos(qk, &s, &c);
      s *= j.axis_sign;
      switch (j.axis_kind) {
        case 0: AxisAndTurn<0>(M, j.axis_sign, c, s, z); break;
        case 1: AxisAndTurn<1>(M, j.axis_sign, c, s, z); break;
        case 2: AxisAndTurn<2>(M, j.axis_sign, c, s, z); break;
        default: GeneralAxisAndTurn(M, j, qk, z, true); break;
      }
    } else {
      switch (j.axis_kind) {
        case 0: AxisAndTurn<0>(M, j.axis_sign, 1.0, 0.0, z, false); break;
        case 1: AxisAndTurn<1>(M, j.axis_sign, 1.0, 0.0, z, false); break;
        case 2: AxisAndTurn<2>(M, j.axis_sign, 1.0, 0.0, z, false); break;
        default: GeneralAxisAndTurn(M, j, qk, z, false); break;
      }
      o[0] = o[0] + z[0] * qk;
      o[1] = o[1] + z[1] * qk;
      o[2] = o[2] + z[2] * qk;
    }
    double* ok = ws.origin[k].data();
    ok[0] = o[0];
    ok[1] = o[1];
    ok[2] = o[2];
    if (kFrames) {
      for (int i = 0; i < 9; ++i) ws.frames[k].data()[i] = M[i];
    }
    while (next_point >= 0 && pts[order[next_point]].frame == k) {  // x = M a + o
      const int i = order[next_point--];
      const double* a = dynamic ? ws.local[i].data() : pts[i].position.data();
      if (dynamic) std::memcpy(ws.point_rotation[i].data(), M, sizeof M);
      const double a0 = a[0], a1 = a[1], a2 = a[2];
      double* x = ws.points[i].data();
      x[0] = (M[0] * a0 + M[3] * a1 + M[6] * a2) + o[0];
      x[1] = (M[1] * a0 + M[4] * a1 + M[7] * a2) + o[1];
      x[2] = (M[2] * a0 + M[5] * a1 + M[8] * a2) + o[2];
    }
  }
  const double e0 = d.endpoint[0], e1 = d.endpoint[1], e2 = d.endpoint[2];
  const double pe[3] = {(M[0] * e0 + M[3] * e1 + M[6] * e2) + o[0],
                        (M[1] * e0 + M[4] * e1 + M[7] * e2) + o[1],
                        (M[2] * e0 + M[5] * e1 + M[8] * e2) + o[2]};
  ws.endpoint = Eigen::Vector3d(pe[0], pe[1], pe[2]);
  const bool rotate = !d.transducer_identity && !(kFrames && world_axes);
  if (d.transducer_identity) {
    ws.R_W_T.setIdentity();
  } else if (d.transducer_in_world) {
    ws.R_W_T = d.transducer_rotation;
  } else {
    ws.R_W_T.noalias() = Eigen::Map<const Eigen::Matrix3d>(M) * d.transducer_rotation;
  }
  const double* T = ws.R_W_T.data();
  ws.J.resize(6, m);
  ws.dL.resize(m);  // every entry is assigned by the sweep below
  ws.tau.resize(m);

  if (kFrames && n == 0) {
    ws.length = 0.0;
    for (int k = 0; k < m; ++k) JacobianColumn(ws, k, joints[k].revolute, pe, rotate, T);
    ws.dL.setZero();
    ws.tau.setZero();
    if (d.coupled) Fold(d, ws, 0.0);
    return true;
  }

  // Muscle: unit segment directions and pulls (over the active points only for a muscle with
  // moving or conditional points).
  double total_length = 0.0;
  bool coincident = false;
  if (dynamic) {
    coincident = !ActivePathPulls(ws, &total_length);
  } else {
    double ub0 = 0.0, ub1 = 0.0, ub2 = 0.0;  // u_{i-1}; zero before the origin
    for (int i = 1; i < n; ++i) {
      const double* a = ws.points[i - 1].data();
      const double* b = ws.points[i].data();
      const double s0 = b[0] - a[0], s1 = b[1] - a[1], s2 = b[2] - a[2];
      const double length = std::sqrt(s0 * s0 + s1 * s1 + s2 * s2);
      if (!(length >= kFastMinSegmentLength)) {
        coincident = true;
        break;
      }
      const double u0 = s0 / length, u1 = s1 / length, u2 = s2 / length;
      total_length += length;
      double* g = ws.pulls[i - 1].data();
      g[0] = ub0 - u0;
      g[1] = ub1 - u1;
      g[2] = ub2 - u2;
      ub0 = u0;
      ub1 = u1;
      ub2 = u2;
    }
    ws.pulls[n - 1] = Eigen::Vector3d(ub0, ub1, ub2);
  }
  ws.length = total_length;
  if (coincident) {
    for (int k = 0; k < m; ++k) JacobianColumn(ws, k, joints[k].revolute, pe, rotate, T);
    ws.dL.setZero();
    ws.tau.setZero();
    if (d.coupled) Fold(d, ws, 0.0);
    return false;
  }

  // Backward sweep over the joints: the Jacobian column and dL/dtheta_k of each joint.
  double ps0 = 0.0, ps1 = 0.0, ps2 = 0.0;  // sum of pulls distal to joint k
  double ms0 = 0.0, ms1 = 0.0, ms2 = 0.0;  // sum of their moments about the world origin
  int next = 0;
  double* dL = ws.dL.data();
  double* tau = ws.tau.data();
  const double minus_force = -(activation * mu.max_force);
  for (int k = m - 1; k >= 0; --k) {
    while (next < sweep_count && pts[order[next]].frame == k) {
      const int i = order[next++];
      const double* x = ws.points[i].data();
      const double* g = ws.pulls[i].data();
      ps0 += g[0];
      ps1 += g[1];
      ps2 += g[2];
      ms0 += x[1] * g[2] - x[2] * g[1];
      ms1 += x[2] * g[0] - x[0] * g[2];
      ms2 += x[0] * g[1] - x[1] * g[0];
    }
    const bool revolute = joints[k].revolute;
    JacobianColumn(ws, k, revolute, pe, rotate, T);
    const double* z = ws.axis[k].data();
    double v;
    if (revolute) {
      const double* ok = ws.origin[k].data();
      const double w0 = ms0 - (ok[1] * ps2 - ok[2] * ps1);
      const double w1 = ms1 - (ok[2] * ps0 - ok[0] * ps2);
      const double w2 = ms2 - (ok[0] * ps1 - ok[1] * ps0);
      v = z[0] * w0 + z[1] * w1 + z[2] * w2;
    } else {
      v = z[0] * ps0 + z[1] * ps1 + z[2] * ps2;
    }
    dL[k] = v;
    tau[k] = minus_force * v;
  }
  if (d.coupled) Fold(d, ws, minus_force);
  if (dynamic) AddMovingPointTerms(mu, ws, minus_force);
  return true;
}

template <bool kFrames>
ISOWRENCH_NOINLINE bool DynamicKinematics(const FlatChain& d, Data::Impl& ws, const double* qv,
                                          int muscle, double activation, bool world_axes) {
  return KinematicsKernel<kFrames, true>(d, ws, qv, muscle, activation, world_axes);
}

template <bool kFrames>
ISOWRENCH_INLINE bool Kinematics(const FlatChain& d, Data::Impl& ws, const double* qv, int muscle,
                                 double activation, bool world_axes) {
  if ((!kFrames || muscle >= 0) && d.muscles[muscle].dynamic) {
    return DynamicKinematics<kFrames>(d, ws, qv, muscle, activation, world_axes);
  }
  return KinematicsKernel<kFrames, false>(d, ws, qv, muscle, activation, world_axes);
}

// Locked coordinates are rigid in the statics: their columns of J and entries of tau are set
// to 0 and their S_p entry to a stiffness on the scale of K (the largest S_t or S_p entry, at
// least 1), so that K has an isolated diagonal there and dtheta is exactly 0 on them; the
// other entries of dtheta and W are those of the statics without the locked columns. The
// reported J and tau (ws.J, ws.tau) keep every column.
ISOWRENCH_NOINLINE WrenchResult SolveLocked(const FlatChain& d, Data::Impl& ws,
                                            const StiffnessSet& stiffness,
                                            const SolveOptions& options) {
  constexpr int S = kMaxDofs;
  const int n = d.n;
  double J[6 * S];
  double tau[S];
  double s_p[S];
  double scale = 1.0;
  for (int r = 0; r < 6; ++r) scale = std::max(scale, stiffness.s_t[r]);
  for (int c = 0; c < n; ++c) scale = std::max(scale, stiffness.s_p[c]);
  for (int c = 0; c < n; ++c) {
    const bool locked = d.locked[c];
    for (int r = 0; r < 6; ++r) {
      J[6 * c + r] = locked ? 0.0 : ws.J(r, c);
      ws.J_rows[r * S + c] = J[6 * c + r];
    }
    tau[c] = locked ? 0.0 : ws.tau[c];
    s_p[c] = locked ? scale : stiffness.s_p[c];
  }
  return SolveDispatch(ws, J, stiffness.s_t.data(), s_p, tau, options);
}

}  // namespace

ISOWRENCH_CLONES bool ComputeKinematics(const Model& model, Data& workspace,
                                        const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                                        double activation) {
  assert(q.size() == model.dof_count());
  return Kinematics<false>(model.impl().flat, workspace.impl(), q.data(), muscle, activation,
                           false);
}

bool ComputeKinematicsWithFrames(const FlatChain& chain, Data::Impl& ws, const double* q,
                                 int muscle, double activation, bool world_axes) {
  return Kinematics<true>(chain, ws, q, muscle, activation, world_axes);
}

WrenchResult SolveStatics(const Model& model, Data& workspace, const StiffnessSet& stiffness,
                          const SolveOptions& options) {
  Data::Impl& ws = workspace.impl();
  const int m = model.dof_count();
  assert(ws.m == m);
  if (stiffness.s_p.size() != m) return Invalid(ws);
  const FlatChain& d = model.impl().flat;
  if (d.any_locked) return SolveLocked(d, ws, stiffness, options);
  return SolveDispatch(ws, ws.J.data(), stiffness.s_t.data(), stiffness.s_p.data(), ws.tau.data(),
                       options);
}

WrenchResult Evaluate(const Model& model, Data& ws, const Eigen::Ref<const Eigen::VectorXd>& q,
                      int muscle, const StiffnessSet& stiffness, double activation,
                      const SolveOptions& options) {
  if (!ComputeKinematics(model, ws, q, muscle, activation)) return Invalid(ws.impl());
  return SolveStatics(model, ws, stiffness, options);
}

WrenchResult SolveStatics(Data& workspace, const Eigen::Ref<const Matrix6Xd>& J,
                          const Vector6d& s_t, const Eigen::Ref<const Eigen::VectorXd>& s_p,
                          const Eigen::Ref<const Eigen::VectorXd>& tau,
                          const SolveOptions& options) {
  Data::Impl& ws = workspace.impl();
  const int m = ws.m;
  if (J.cols() != m || s_p.size() != m || tau.size() != m || !J.allFinite()) return Invalid(ws);
  ws.J = J;
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < m; ++k) ws.J_rows[r * kMaxDofs + k] = J(r, k);
  }
  ws.tau = tau;
  double s_p_copy[kMaxDofs];
  for (int i = 0; i < m; ++i) s_p_copy[i] = s_p[i];
  return SolveDispatch(ws, ws.J.data(), s_t.data(), s_p_copy, ws.tau.data(), options);
}

}  // namespace isowrench
