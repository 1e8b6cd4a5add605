// The engine's scalar entry points: ComputeKinematics, SolveStatics and Evaluate on one
// posture, the Data workspace, and the eigen-solve for the (nearly) singular statics. The
// kinematics and the Cholesky statics are the templates of fast/kernel.hpp, the same code the
// batch runs on SIMD lanes (lanes.cpp).

#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "fast/fast_impl.hpp"
#include "fast/kernel.hpp"
#include "fast/simd.hpp"
#include "isowrench/error.hpp"
#include "model/function_impl.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace {
// The eigen-solve used when the Cholesky pivots say K is (nearly) singular: the same rank and
// excitation decisions as SolveStatics, on the workspace's fixed-size buffers. J: row-major,
// 6 x m, row r at J + r * js.
WrenchResult SolveByEigen(Data::Impl& ws, int m, const double* J, int js, const double* s_t,
                          const double* s_p, const double* tau, const SolveOptions& options) {
  WrenchResult out;
  JointMatrix& K = ws.K_full;
  K.resize(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) {
      double sum = i == j ? s_p[i] : 0.0;
      for (int r = 0; r < 6; ++r) sum += s_t[r] * J[r * js + i] * J[r * js + j];
      K(i, j) = K(j, i) = sum;
    }
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
    for (int j = 0; j < m; ++j) v += J[r * js + j] * ws.dtheta[j];
    out.wrench[r] = s_t[r] * v;
  }
  out.status = nulls == 0 ? StaticsStatus::kOk : StaticsStatus::kSelfMotionHeld;
  return out;
}

// Inputs of a solve are checked, not trusted: negative or non-finite values give kInvalidInput.
// Branch-free: 0 * v is 0 for finite v and NaN for inf/NaN, so the sum of those is 0 exactly
// when every entry is finite; the minimum catches negative stiffness. Four entries per vector
// (whole vectors only: the arrays hold exactly their entries), the rest one by one. N > 0
// fixes m at compile time (the loops unroll).
template <int N>
ISOWRENCH_INLINE bool ValidSolveInput(int m_runtime, const double* s_t, const double* s_p,
                                      const double* tau) {
  const int m = N > 0 ? N : m_runtime;
  V4 nonfinite = ISOWRENCH_V4_SPLAT(0.0);
  V4 lowest = ISOWRENCH_V4_SPLAT(0.0);
  auto add = [&](const double* v, bool stiffness) ISOWRENCH_LAMBDA_INLINE {
    V4 x;
    std::memcpy(&x, v, sizeof x);
    nonfinite += 0.0 * x;
    if (stiffness) lowest = x < lowest ? x : lowest;
  };
  add(s_t, true);
  add(s_t + 2, true);  // entries 2 .. 5 (2 and 3 twice)
  double tail_nonfinite = 0.0;
  double tail_lowest = 0.0;
  ISOWRENCH_UNROLL
  for (int i = 0; i + 4 <= m; i += 4) {
    add(s_p + i, true);
    add(tau + i, false);
  }
  ISOWRENCH_UNROLL
  for (int i = m / 4 * 4; i < m; ++i) {
    tail_nonfinite += 0.0 * s_p[i] + 0.0 * tau[i];
    tail_lowest = std::min(tail_lowest, s_p[i]);
  }
  const double sum =
      ((nonfinite[0] + nonfinite[1]) + (nonfinite[2] + nonfinite[3])) + tail_nonfinite;
  const double low = std::min(
      std::min(std::min(lowest[0], lowest[1]), std::min(lowest[2], lowest[3])), tail_lowest);
  return sum == 0.0 && low >= 0.0;
}

WrenchResult Invalid(Data::Impl& ws) {
  ws.dtheta.setZero(ws.m);
  ws.self_motion.resize(ws.m, 0);
  return WrenchResult{};
}

// The statics of one evaluation (inputs checked first): the kernel's Cholesky (m fixed at
// compile time up to 10) on J and S_t J, the eigen-solve when it cannot decide. J: row-major,
// row stride kMaxDofs (Data::Impl::Jr). The result goes to `out`, which holds a default
// WrenchResult (invalid input) on entry: written in place, the caller's result is not copied.
template <int N>
ISOWRENCH_INLINE void SolveWith(Data::Impl& ws, const double* J, const double* s_t,
                                const double* s_p, const double* tau, const SolveOptions& options,
                                WrenchResult& out) {
  const int m = N > 0 ? N : ws.m;
  if (!ValidSolveInput<N>(m, s_t, s_p, tau)) {
    Invalid(ws);
    return;
  }
  // S_t J, four columns per vector (up to the next multiple of 4: the Cholesky reads whole
  // vectors).
  alignas(32) double sJ[6 * kMaxDofs];
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    const V4 scale = ISOWRENCH_V4_SPLAT(s_t[r]);
    ISOWRENCH_UNROLL
    for (int c = 0; c < (m + 3) / 4; ++c) {
      V4 v;
      std::memcpy(&v, J + r * kMaxDofs + 4 * c, sizeof v);
      v *= scale;
      std::memcpy(sJ + r * kMaxDofs + 4 * c, &v, sizeof v);
    }
  }
  bool undecided;  // (dtheta has m entries from construction on)
  kernel::Cholesky<N, true>(m, J, sJ, kMaxDofs, s_t, s_p, tau, options.cholesky_pivot_tolerance,
                            ws.U, ws.dtheta.data(), out.wrench.data(), undecided);
  if (undecided) {
    out = SolveByEigen(ws, m, J, kMaxDofs, s_t, s_p, tau, options);
    return;
  }
  out.status = StaticsStatus::kOk;
  ws.self_motion.resize(m, 0);
}

ISOWRENCH_INLINE void SolveAnyM(Data::Impl& ws, const double* J, const double* s_t,
                                const double* s_p, const double* tau, const SolveOptions& options,
                                WrenchResult& out) {
  switch (ws.m) {
    case 1: return SolveWith<1>(ws, J, s_t, s_p, tau, options, out);
    case 2: return SolveWith<2>(ws, J, s_t, s_p, tau, options, out);
    case 3: return SolveWith<3>(ws, J, s_t, s_p, tau, options, out);
    case 4: return SolveWith<4>(ws, J, s_t, s_p, tau, options, out);
    case 5: return SolveWith<5>(ws, J, s_t, s_p, tau, options, out);
    case 6: return SolveWith<6>(ws, J, s_t, s_p, tau, options, out);
    case 7: return SolveWith<7>(ws, J, s_t, s_p, tau, options, out);
    case 8: return SolveWith<8>(ws, J, s_t, s_p, tau, options, out);
    case 9: return SolveWith<9>(ws, J, s_t, s_p, tau, options, out);
    case 10: return SolveWith<10>(ws, J, s_t, s_p, tau, options, out);
    default: return SolveWith<0>(ws, J, s_t, s_p, tau, options, out);
  }
}

ISOWRENCH_CLONES WrenchResult SolveDispatch(Data::Impl& ws, const double* J, const double* s_t,
                                            const double* s_p, const double* tau,
                                            const SolveOptions& options) {
  WrenchResult out;
  SolveAnyM(ws, J, s_t, s_p, tau, options, out);
  return out;
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
  for (double& v : Jr) v = 0.0;
  J.setZero(6, m);
  dL.setZero(m);
  tau.setZero(m);
  dtheta.setZero(m);
  K_full.setZero(m, m);
  self_motion.resize(m, 0);
  for (double& v : U) v = 0.0;
  for (int c = m; c < (m + 3) / 4 * 4; ++c) {
    staged[c] = staged[kW + c] = staged[kP + c] = ISOWRENCH_V4_SPLAT(0.0);
  }
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

const JacobianBuffer& Data::jacobian() const { return impl_->Jacobian(); }
const JointVector& Data::tau() const { return impl_->tau; }
const JointVector& Data::muscle_length_gradient() const { return impl_->dL; }
double Data::muscle_length() const { return impl_->length; }
const Eigen::Vector3d& Data::endpoint_position() const {
  impl_->endpoint_copy = impl_->Endpoint();
  return impl_->endpoint_copy;
}
const Eigen::Matrix3d& Data::transducer_rotation() const {
  impl_->R_W_T_copy = impl_->TransducerRotation();
  return impl_->R_W_T_copy;
}
const JointVector& Data::dtheta() const { return impl_->dtheta; }
const JointMatrix& Data::self_motion() const { return impl_->self_motion; }
// ---- Evaluation -----------------------------------------------------------------------------

namespace {

const FastMuscle kNoMuscle{};  // the muscle of a kinematics call without one

// Coupled chains: the joint positions q_joint_k = f_k(q[c_k]) and, for the driven joints (the
// ones the folds read), dq_joint_k/dq: joint k first takes coordinate k (four per vector), the
// owners of FlatChain::moved_positions their coordinates, then the driven joints evaluate their
// couplings.
ISOWRENCH_INLINE void Couple(const FlatChain& d, Data::Impl& ws, const double* q) {
  const int n = d.n;
  double* q_joint = ws.q_joint;
  if (n >= 4) {  // whole vectors, the last one ending at n (it may overlap the one before)
    V4 v;
    for (int i = 0; i + 4 < n; i += 4) {
      std::memcpy(&v, q + i, sizeof v);
      std::memcpy(q_joint + i, &v, sizeof v);
    }
    std::memcpy(&v, q + n - 4, sizeof v);
    std::memcpy(q_joint + n - 4, &v, sizeof v);
  } else {
    for (int i = 0; i < n; ++i) q_joint[i] = q[i];
  }
  for (const FlatChain::MovedPosition& p : d.moved_positions) q_joint[p.joint] = q[p.column];
  for (const FlatChain::DrivenJoint& c : d.driven_joints) {  // knot functions inline
    const double a = q[c.column];
    double* value = &q_joint[c.joint];
    double* slope = &ws.dq_joint[c.joint];
    if (!c.scan.ValueAndSlope(a, value, slope)) {
      d.coupling[c.joint].ValueAndDerivative(a, value, slope);
    }
  }
}

// The kernel on one posture q (coordinates). kFrames: the public kinematics functions (frames
// stored, muscle < 0 allowed, J in world axes if world_axes); the evaluation path runs
// kFrames = false. A muscle with moving or conditional points runs the kDynamic
// instantiation (out of line), the others the one where those steps are compiled out.
// kCoupled: any chain (kernel::Kinematics); false: a chain without couplings only.
template <bool kFrames, bool kDynamic, bool kCoupled>
ISOWRENCH_INLINE bool Kinematics(const FlatChain& d, Data::Impl& ws, const double* q, int muscle,
                                 double activation, bool world_axes) {
  assert(ws.m == d.n);
  assert(muscle < static_cast<int>(d.muscles.size()) && (kFrames || muscle >= 0));
  const FastMuscle& mu = (kFrames && muscle < 0) ? kNoMuscle : d.muscles[muscle];
  if (kDynamic) PreparePathPoints(mu, q, ws);
  if (kCoupled && d.coupled) {
    Couple(d, ws, q);
    q = ws.q_joint;
  }
  const double minus_force = -(activation * mu.max_force);
  const bool rotate = !d.transducer_identity && !(kFrames && world_axes);
  bool coincident;
  kernel::Kinematics<kFrames, kDynamic, kCoupled>(d, ws, q, mu, minus_force, rotate, coincident);
  if (coincident) {
    ws.dL.setZero();
    ws.tau.setZero();
    return false;
  }
  if (kDynamic) AddMovingPointTerms(mu, ws, minus_force);
  return true;
}

template <bool kFrames>
ISOWRENCH_NOINLINE bool DynamicKinematics(const FlatChain& d, Data::Impl& ws, const double* q,
                                          int muscle, double activation, bool world_axes) {
  return Kinematics<kFrames, true, true>(d, ws, q, muscle, activation, world_axes);
}

// ComputeKinematics on a chain with couplings, in a function of its own (as EvaluateChain, below:
// inlined, it would crowd the registers and stack of the chains without couplings).
ISOWRENCH_CLONES ISOWRENCH_NOINLINE bool CoupledKinematics(const FlatChain& d, Data::Impl& ws,
                                                           const double* q, int muscle,
                                                           double activation) {
  return Kinematics<false, false, true>(d, ws, q, muscle, activation, false);
}

// Muscles with moving or conditional points, the public kinematics functions and chains with
// couplings run the general kernel; the evaluation of a chain without couplings its own.
template <bool kFrames>
ISOWRENCH_INLINE bool AnyKinematics(const FlatChain& d, Data::Impl& ws, const double* q, int muscle,
                                    double activation, bool world_axes) {
  if ((!kFrames || muscle >= 0) && d.muscles[muscle].dynamic) {
    return DynamicKinematics<kFrames>(d, ws, q, muscle, activation, world_axes);
  }
  if constexpr (kFrames) {
    return Kinematics<true, false, true>(d, ws, q, muscle, activation, world_axes);
  } else if (d.coupled) {
    return CoupledKinematics(d, ws, q, muscle, activation);
  } else {
    return Kinematics<false, false, false>(d, ws, q, muscle, activation, world_axes);
  }
}

// Locked coordinates are rigid in the statics: their columns of J and entries of tau are set
// to 0 and their S_p entry to a stiffness on the scale of K (the largest S_t or S_p entry, at
// least 1), so that K has an isolated diagonal there and dtheta is exactly 0 on them; the
// other entries of dtheta and W are those of the statics without the locked columns. The
// reported J and tau (ws.Jr, ws.tau) keep every column.
ISOWRENCH_NOINLINE WrenchResult SolveLocked(const FlatChain& d, Data::Impl& ws,
                                            const StiffnessSet& stiffness,
                                            const SolveOptions& options) {
  constexpr int S = kMaxDofs;
  const int n = d.n;
  alignas(32) double J[6 * S] = {};  // row-major, row stride S (as Data::Impl::Jr)
  double tau[S];
  double s_p[S];
  double scale = 1.0;
  for (int r = 0; r < 6; ++r) scale = std::max(scale, stiffness.s_t[r]);
  for (int c = 0; c < n; ++c) scale = std::max(scale, stiffness.s_p[c]);
  for (int c = 0; c < n; ++c) {
    const bool locked = d.locked[c];
    for (int r = 0; r < 6; ++r) {
      J[r * S + c] = locked ? 0.0 : ws.Jr[r * S + c];
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
  return AnyKinematics<false>(model.impl().flat, workspace.impl(), q.data(), muscle, activation,
                              false);
}

bool ComputeKinematicsWithFrames(const FlatChain& chain, Data::Impl& ws, const double* q,
                                 int muscle, double activation, bool world_axes) {
  return AnyKinematics<true>(chain, ws, q, muscle, activation, world_axes);
}

WrenchResult SolveStatics(const Model& model, Data& workspace, const StiffnessSet& stiffness,
                          const SolveOptions& options) {
  Data::Impl& ws = workspace.impl();
  const FlatChain& d = model.impl().flat;
  assert(ws.m == d.n);
  if (stiffness.s_p.size() != d.n) return Invalid(ws);
  if (d.any_locked) return SolveLocked(d, ws, stiffness, options);
  return SolveDispatch(ws, ws.Jr, stiffness.s_t.data(), stiffness.s_p.data(), ws.tau.data(),
                       options);
}

namespace {

// ComputeKinematics and SolveStatics in one function (one call, the solve's m-dispatch inlined),
// on a chain without couplings (kCoupled = false) or any chain (true). The result goes to
// `out`, which holds a default WrenchResult (invalid input) on entry.
template <bool kCoupled>
ISOWRENCH_INLINE void EvaluateWith(const FlatChain& d, Data::Impl& ws, const double* q, int muscle,
                                   const StiffnessSet& stiffness, double activation,
                                   const SolveOptions& options, WrenchResult& out) {
  const bool valid = d.muscles[muscle].dynamic
                         ? DynamicKinematics<false>(d, ws, q, muscle, activation, false)
                         : Kinematics<false, false, kCoupled>(d, ws, q, muscle, activation, false);
  if (!valid || stiffness.s_p.size() != d.n) {
    Invalid(ws);
  } else if (d.any_locked) {
    out = SolveLocked(d, ws, stiffness, options);
  } else {
    SolveAnyM(ws, ws.Jr, stiffness.s_t.data(), stiffness.s_p.data(), ws.tau.data(), options, out);
  }
}

// Evaluate on a chain without couplings (kCoupled = false) or with them: two functions, so that
// neither shares the other's registers and stack.
template <bool kCoupled>
ISOWRENCH_CLONES ISOWRENCH_NOINLINE WrenchResult EvaluateChain(
    const Model& model, Data& workspace, const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
    const StiffnessSet& stiffness, double activation, const SolveOptions& options) {
  const FlatChain& d = model.impl().flat;
  Data::Impl& ws = workspace.impl();
  assert(q.size() == d.n && ws.m == d.n);
  WrenchResult out;  // every path returns this object (no copy of the result)
  EvaluateWith<kCoupled>(d, ws, q.data(), muscle, stiffness, activation, options, out);
  return out;
}

}  // namespace

ISOWRENCH_CLONES WrenchResult Evaluate(const Model& model, Data& workspace,
                                       const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                                       const StiffnessSet& stiffness, double activation,
                                       const SolveOptions& options) {
  return model.impl().flat.coupled
             ? EvaluateChain<true>(model, workspace, q, muscle, stiffness, activation, options)
             : EvaluateChain<false>(model, workspace, q, muscle, stiffness, activation, options);
}

WrenchResult SolveStatics(Data& workspace, const Eigen::Ref<const Matrix6Xd>& J,
                          const Vector6d& s_t, const Eigen::Ref<const Eigen::VectorXd>& s_p,
                          const Eigen::Ref<const Eigen::VectorXd>& tau,
                          const SolveOptions& options) {
  Data::Impl& ws = workspace.impl();
  const int m = ws.m;
  if (J.cols() != m || s_p.size() != m || tau.size() != m || !J.allFinite()) return Invalid(ws);
  ws.SetJacobian(J);
  ws.tau = tau;
  double s_p_copy[kMaxDofs];
  for (int i = 0; i < m; ++i) s_p_copy[i] = s_p[i];
  return SolveDispatch(ws, ws.Jr, s_t.data(), s_p_copy, ws.tau.data(), options);
}

}  // namespace isowrench
