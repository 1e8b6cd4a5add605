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
// excitation decisions as SolveStatics, on the workspace's buffers (a small chain's of fixed
// size; a large chain's sized at construction). J: row-major, 6 x m, row r at J + r * js.
template <class W>
WrenchResult SolveByEigen(W& ws, int m, const double* J, int js, const double* s_t,
                          const double* s_p, const double* tau, const SolveOptions& options) {
  WrenchResult out;
  auto& K = ws.K_full;
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
  ws.dtheta.setZero();
  ws.self_motion_count = nulls;
  Eigen::Map<Eigen::MatrixXd> self_motion(ws.self_motion_data.data(), m, nulls);
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
      self_motion.col(c++) = sign * V.col(i);
      if (std::abs(v_tau) > options.excitation_tolerance * tau_norm) excited = true;
    } else {
      ws.dtheta += V.col(i) * (v_tau / lambda[i]);
    }
  }
  out.self_motion_count = nulls;
  if (excited) {
    out.status = StaticsStatus::kSelfMotion;
    ws.dtheta.setZero();
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
  ws.dtheta.setZero();
  ws.self_motion_count = 0;
  return WrenchResult{};
}

// The statics of one evaluation (inputs checked first): the kernel's Cholesky (m fixed at
// compile time up to 10 on a small chain; N < 0: a large chain's, m at run time) on J and
// S_t J, the eigen-solve when it cannot decide. J: row-major, row stride ws.kStride
// (Data::Impl::Jr). The result goes to `out`, which holds a default WrenchResult (invalid
// input) on entry: written in place, the caller's result is not copied.
template <int N, class W>
ISOWRENCH_INLINE void SolveWith(W& ws, const double* J, const double* s_t, const double* s_p,
                                const double* tau, const SolveOptions& options, WrenchResult& out) {
  const int m = N > 0 ? N : ws.m;
  const int S = ws.kStride;
  if (!ValidSolveInput<N>(m, s_t, s_p, tau)) {
    Invalid(ws);
    return;
  }
  // S_t J, four columns per vector (up to the next multiple of 4: the Cholesky reads whole
  // vectors); on the stack for a small chain.
  alignas(32) double sJ_small[W::kLarge ? 1 : 6 * kSmallJoints];
  double* sJ = sJ_small;
  kernel::CholeskyScratch<double> scratch;
  if constexpr (W::kLarge) {
    sJ = ws.sJ.data();
    scratch = {ws.inv_diag_scratch.data(), ws.y_scratch.data()};
  }
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    const V4 scale = ISOWRENCH_V4_SPLAT(s_t[r]);
    ISOWRENCH_UNROLL
    for (int c = 0; c < (m + 3) / 4; ++c) {
      V4 v;
      std::memcpy(&v, J + r * S + 4 * c, sizeof v);
      v *= scale;
      std::memcpy(sJ + r * S + 4 * c, &v, sizeof v);
    }
  }
  bool undecided;  // (dtheta holds the stride's entries from construction on)
  kernel::Cholesky<N, true>(m, J, sJ, S, s_t, s_p, tau, options.cholesky_pivot_tolerance,
                            ws.U.data(), S, ws.dtheta_data.data(), out.wrench.data(), undecided,
                            scratch);
  if (undecided) {
    out = SolveByEigen(ws, m, J, S, s_t, s_p, tau, options);
    return;
  }
  out.status = StaticsStatus::kOk;
  ws.self_motion_count = 0;
}

template <class W>
ISOWRENCH_INLINE void SolveAnyM(W& ws, const double* J, const double* s_t, const double* s_p,
                                const double* tau, const SolveOptions& options, WrenchResult& out) {
  if constexpr (W::kLarge) {
    SolveWith<-1>(ws, J, s_t, s_p, tau, options, out);
  } else {
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
}

template <class W>
ISOWRENCH_CLONES WrenchResult SolveDispatch(W& ws, const double* J, const double* s_t,
                                            const double* s_p, const double* tau,
                                            const SolveOptions& options) {
  WrenchResult out;
  SolveAnyM(ws, J, s_t, s_p, tau, options, out);
  return out;
}

// Runs f on the workspace as its shape (SmallWorkspace or LargeWorkspace).
template <class F>
ISOWRENCH_INLINE auto WithShape(bool large, Data::Impl& ws, F&& f) {
  return large ? f(static_cast<LargeWorkspace&>(ws)) : f(static_cast<SmallWorkspace&>(ws));
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
         "match, two consecutive muscle path points coincide at this posture, or the muscle's "
         "force model has no equilibrium at its length; W not computed (zeros)";
}

// ---- Data --------------------------------------------------------------------------

Data::Impl::Impl(const WorkspaceSize& s, const FlatChain* chain)
    : chain_id(chain != nullptr ? chain->id : 0),
      model_name(chain != nullptr ? chain->name : ""),
      size(s),
      m(s.columns) {
  J.setZero(6, m);
  if (chain != nullptr) {
    for (const FastMuscle& muscle : chain->muscles) {
      if (!muscle.wraps.empty()) wrap = std::make_unique<WrapWorkspace>();
    }
  }
}

Data::Impl::~Impl() = default;

void Data::Impl::SetViews() {
  new (&dL) Eigen::Map<Eigen::VectorXd>(dL_data.data(), m);
  new (&tau) Eigen::Map<Eigen::VectorXd>(tau_data.data(), m);
  new (&dtheta) Eigen::Map<Eigen::VectorXd>(dtheta_data.data(), m);
}

// Every array zeroed (value-initialised): the columns from m to the next multiple of 4 of J,
// the staging, dL, tau and dtheta are read in whole vectors and must stay 0 (or finite).
SmallWorkspace::SmallWorkspace(const WorkspaceSize& s, const FlatChain* chain)
    : Impl(s, chain),
      origin(),
      axis(),
      points(),
      pulls(),
      frames(),
      q_joint(),
      dq_joint(),
      staged(),
      Jr(),
      dL_data(),
      tau_data(),
      dtheta_data(),
      U(),
      K_full(Matrix::Zero(s.columns, s.columns)),
      eigen(s.columns),
      self_motion_data(),
      local(),
      point_rotation(),
      active(),
      moving_slope() {
  auto view = [](auto& array, std::size_t n) { return Buffer(array.data(), n); };
  const auto joints = static_cast<std::size_t>(kSmallJoints);
  const auto points_count = static_cast<std::size_t>(kSmallPoints);
  Impl::origin = view(origin, joints);
  Impl::axis = view(axis, joints);
  Impl::points = view(points, points_count);
  Impl::pulls = view(pulls, points_count);
  Impl::frames = view(frames, joints);
  Impl::q_joint = view(q_joint, joints);
  Impl::dq_joint = view(dq_joint, joints);
  Impl::Jr = view(Jr, Jr.size());
  Impl::dL_data = view(dL_data, dL_data.size());
  Impl::tau_data = view(tau_data, tau_data.size());
  Impl::dtheta_data = view(dtheta_data, dtheta_data.size());
  Impl::self_motion_data = view(self_motion_data, self_motion_data.size());
  Impl::local = view(local, points_count);
  Impl::point_rotation = view(point_rotation, points_count);
  Impl::active = view(active, points_count);
  Impl::moving_slope = view(moving_slope, moving_slope.size());
  SetViews();
}

LargeWorkspace::LargeWorkspace(const WorkspaceSize& s, const FlatChain* chain)
    : Impl(s, chain), K_full(Eigen::MatrixXd::Zero(s.columns, s.columns)), eigen(s.columns) {
  kStride = s.stride;
  kW = s.slots;
  kP = 2 * s.slots;
  cos_offset = RoundUpTo4(s.joints) + 4;
  Lay(arena);
  arena.Allocate();
  Lay(arena);
  SetViews();
}

// Every buffer, in one allocation, zeroed (as SmallWorkspace's arrays).
void LargeWorkspace::Lay(WorkspaceArena& a) {
  const auto joints = static_cast<std::size_t>(size.joints);
  const auto points_count = static_cast<std::size_t>(size.points);
  const auto stride = static_cast<std::size_t>(size.stride);
  const auto columns = static_cast<std::size_t>(m);
  a.Take(origin, joints);
  a.Take(axis, joints);
  a.Take(points, points_count);
  a.Take(pulls, points_count);
  a.Take(frames, joints);
  a.Take(q_joint, joints);
  a.Take(dq_joint, joints);
  a.Take(staged, 3 * static_cast<std::size_t>(size.slots));
  a.Take(trig, 2 * static_cast<std::size_t>(cos_offset));
  // (J and its copies: 12 entries more, which the large Cholesky's last blocks read past row 5)
  a.Take(Jr, 6 * stride + 12);
  a.Take(dL_data, stride);
  a.Take(tau_data, stride);
  a.Take(dtheta_data, stride);
  a.Take(U, stride * columns);
  a.Take(sJ, 6 * stride + 12);
  a.Take(locked_J, 6 * stride + 12);
  a.Take(locked_tau, stride);
  a.Take(s_p_copy, stride);
  a.Take(inv_diag_scratch, columns);
  a.Take(y_scratch, stride);  // (LargeSolveWithFactor writes whole vectors)
  a.Take(self_motion_data, columns * columns);
  a.Take(local, points_count);
  a.Take(point_rotation, points_count);
  a.Take(active, points_count);
  a.Take(moving_slope, static_cast<std::size_t>(size.moving));
}

namespace {
std::unique_ptr<Data::Impl> MakeWorkspace(const WorkspaceSize& size, const FlatChain* chain) {
  if (size.large) return std::make_unique<LargeWorkspace>(size, chain);
  return std::make_unique<SmallWorkspace>(size, chain);
}
}  // namespace

Data::Data(const Model& model)
    : impl_(MakeWorkspace(WorkspaceSize::Of(model.impl().flat), &model.impl().flat)) {}

Data::Data(int dof_count) {
  if (dof_count < 1) {
    throw Error("Data: dof count " + std::to_string(dof_count) + " must be at least 1");
  }
  impl_ = MakeWorkspace(WorkspaceSize::Raw(dof_count), nullptr);
}

Data::~Data() = default;
Data::Data(Data&&) noexcept = default;
Data& Data::operator=(Data&&) noexcept = default;

const JacobianBuffer& Data::jacobian() const { return impl_->Jacobian(); }
JointVectorView Data::tau() const { return JointVectorView(impl_->tau_data.data(), impl_->m); }
JointVectorView Data::muscle_length_gradient() const {
  return JointVectorView(impl_->dL_data.data(), impl_->m);
}
double Data::muscle_length() const { return impl_->length; }
const Eigen::Vector3d& Data::endpoint_position() const {
  impl_->endpoint_copy = impl_->Endpoint();
  return impl_->endpoint_copy;
}
const Eigen::Matrix3d& Data::transducer_rotation() const {
  impl_->R_W_T_copy = impl_->TransducerRotation();
  return impl_->R_W_T_copy;
}
JointVectorView Data::dtheta() const {
  return JointVectorView(impl_->dtheta_data.data(), impl_->m);
}
JointMatrixView Data::self_motion() const {
  return JointMatrixView(impl_->self_motion_data.data(), impl_->m, impl_->self_motion_count);
}
// ---- Evaluation -----------------------------------------------------------------------------

namespace {

const FastMuscle kNoMuscle{};  // the muscle of a kinematics call without one

// The force stage of a muscle with a force model (FastMuscle::force_curve), after the path
// stage: F = MuscleForceAt(L_MT, a).force (the one definition, here by MuscleTensionOf: the
// force and status only) into ws.force, and tau (the kernel's -dL/dq times a unit force)
// scaled by F. A length with no equilibrium (MuscleForceStatus::kNoEquilibrium) leaves tau zero
// and returns false (kInvalidInput).
// @throws Error for an activation outside [0, 1] (MuscleForceModel::Tension).
ISOWRENCH_INLINE bool ApplyForceStage(const FastMuscle& mu, Data::Impl& ws, double activation) {
  const double f = MuscleTensionOf(mu, ws.length, activation, &ws.force_status);
  ws.force = f;
  if (ws.force_status == MuscleForceStatus::kNoEquilibrium) {
    ws.tau.setZero();
    return false;
  }
  // Whole 4-double vectors (the buffer holds the stride; the entries past m stay 0).
  const V4 scale = ISOWRENCH_V4_SPLAT(f);
  double* tau = ws.tau_data.data();
  for (int c = 0; c < ws.m; c += 4) {
    V4 v;
    std::memcpy(&v, tau + c, sizeof v);
    v *= scale;
    std::memcpy(tau + c, &v, sizeof v);
  }
  return true;
}

// Coupled chains: the joint positions q_joint_k = f_k(q[c_k]) and, for the driven joints (the
// ones the folds read), dq_joint_k/dq: joint k first takes coordinate k (four per vector), the
// owners of FlatChain::moved_positions their coordinates, then the driven joints evaluate their
// couplings.
template <class W>
ISOWRENCH_INLINE void Couple(const FlatChain& d, W& ws, const double* q) {
  const int n = d.n;
  double* q_joint = ws.q_joint.data();
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
// kCoupled: any chain (kernel::Kinematics); false: a chain without couplings only. kForce: the
// muscle has a force model (FastMuscle::force_curve; the instantiations with frames or moving
// points test it at run time, the evaluation of a fixed path is told at compile time, so that
// a constant-force muscle runs the code it always ran). W: the workspace's shape
// (SmallWorkspace, LargeWorkspace).
// kWrap: a muscle over one cylinder with fixed points (FastMuscle::one_cylinder), the kernel's
// kWrap instantiation (its force model tested at run time, as kDynamic's).
template <bool kFrames, bool kDynamic, bool kCoupled, bool kForce = false, bool kWrap = false,
          class W>
ISOWRENCH_INLINE bool Kinematics(const FlatChain& d, W& ws, const double* q, int muscle,
                                 double activation, bool world_axes) {
  assert(ws.m == d.n);
  assert(muscle < static_cast<int>(d.muscles.size()) && (kFrames || muscle >= 0));
  // (EvaluatedMuscle: this Data's copy when SetPathPointOffsets moved the muscle's points)
  const FastMuscle& mu = (kFrames && muscle < 0) ? kNoMuscle : EvaluatedMuscle(d, ws, muscle);
  if (kDynamic) PreparePathPoints(mu, q, ws);
  if (kCoupled && d.coupled) {
    Couple(d, ws, q);
    q = ws.q_joint.data();
  }
  // The force stage: a constant-force muscle's F = a * max_force goes into the kernel; a muscle
  // with a force model runs the kernel with a unit force, then ApplyForceStage scales tau by
  // F(L_MT, a) (bit for bit the same tau as the kernel with -F: -1 * x is exact).
  const bool force_curve = kForce || ((kFrames || kDynamic || kWrap) && mu.force_curve);
  const double minus_force = force_curve ? -1.0 : -(activation * mu.max_force);
  const bool rotate = !d.transducer_identity && !(kFrames && world_axes);
  bool coincident;
  kernel::Kinematics<kFrames, kDynamic, kCoupled, kWrap>(d, ws, q, mu, minus_force, rotate,
                                                         coincident);
  if (coincident) {
    ws.dL.setZero();
    ws.tau.setZero();
    return false;
  }
  if (kDynamic) AddMovingPointTerms(mu, ws, minus_force);
  if (force_curve) return ApplyForceStage(mu, ws, activation);
  return true;
}

// A muscle with a force model on a fixed path: the general kernel, then the force stage (cloned
// per target as the plain evaluation: the lanes' vectors are AVX2 ones there).
template <bool kFrames, class W>
ISOWRENCH_CLONES ISOWRENCH_NOINLINE bool ForceKinematics(const FlatChain& d, W& ws, const double* q,
                                                         int muscle, double activation,
                                                         bool world_axes) {
  if constexpr (!kFrames) {
    if (!d.coupled)
      return Kinematics<false, false, false, true>(d, ws, q, muscle, activation, false);
  }
  return Kinematics<kFrames, false, true, true>(d, ws, q, muscle, activation, world_axes);
}

// A muscle over one cylinder with fixed points (FastMuscle::one_cylinder) on a small chain: the
// kernel with the cylinder's path stage instead of the general one of moving points and wraps
// (docs/performance.md "Wrapping muscles"); cloned per target as the plain evaluation.
template <class W>
ISOWRENCH_CLONES ISOWRENCH_NOINLINE bool OneCylinderKinematics(const FlatChain& d, W& ws,
                                                               const double* q, int muscle,
                                                               double activation) {
  if (!d.coupled)
    return Kinematics<false, false, false, false, true>(d, ws, q, muscle, activation, false);
  return Kinematics<false, false, true, false, true>(d, ws, q, muscle, activation, false);
}

// The muscles off the plain evaluation path (FastMuscle::special): moving or conditional points
// (the kDynamic kernel), or a force model on a fixed path (ForceKinematics). (One cylinder over
// fixed points: OneCylinderKinematics, called by AnyKinematics and EvaluateWith; the general
// path here gives the same numbers.)
template <bool kFrames, class W>
ISOWRENCH_NOINLINE bool DynamicKinematics(const FlatChain& d, W& ws, const double* q, int muscle,
                                          double activation, bool world_axes) {
  if constexpr (!W::kLarge) {  // (a large chain: the kDynamic kernel does both, at run time)
    if (muscle >= 0 && !d.muscles[muscle].dynamic) {
      return ForceKinematics<kFrames>(d, ws, q, muscle, activation, world_axes);
    }
  }
  return Kinematics<kFrames, true, true>(d, ws, q, muscle, activation, world_axes);
}

// The evaluation of a muscle off the plain path (FastMuscle::special): a force model on a fixed
// path straight to ForceKinematics (DynamicKinematics' large frame costs ~40 instructions), one
// cylinder over fixed points to OneCylinderKinematics, moving or conditional points and other
// wraps to DynamicKinematics.
template <class W>
ISOWRENCH_NOINLINE bool SpecialKinematics(const FlatChain& d, W& ws, const double* q, int muscle,
                                          double activation) {
  if (d.muscles[muscle].one_cylinder) return OneCylinderKinematics(d, ws, q, muscle, activation);
  if (!d.muscles[muscle].dynamic) {
    return ForceKinematics<false>(d, ws, q, muscle, activation, false);
  }
  return DynamicKinematics<false>(d, ws, q, muscle, activation, false);
}

// ComputeKinematics on a chain with couplings, in a function of its own (as EvaluateChain, below:
// inlined, it would crowd the registers and stack of the chains without couplings).
template <class W>
ISOWRENCH_CLONES ISOWRENCH_NOINLINE bool CoupledKinematics(const FlatChain& d, W& ws,
                                                           const double* q, int muscle,
                                                           double activation) {
  return Kinematics<false, false, true>(d, ws, q, muscle, activation, false);
}

// Muscles with moving or conditional points, the public kinematics functions and chains with
// couplings run the general kernel; the evaluation of a small chain without couplings its own.
// A large chain has two kernel instantiations only (compile time): the evaluation's general
// kernel, and one with frames and moving points for everything else (the public kinematics
// functions, any muscle or none; and the evaluations of muscles with moving points, which store
// frames they do not need).
template <bool kFrames, class W>
ISOWRENCH_INLINE bool AnyKinematics(const FlatChain& d, W& ws, const double* q, int muscle,
                                    double activation, bool world_axes) {
  if constexpr (W::kLarge) {
    if (kFrames || d.muscles[muscle].special) {
      return DynamicKinematics<true>(d, ws, q, muscle, activation, kFrames && world_axes);
    }
    return CoupledKinematics(d, ws, q, muscle, activation);
  } else {
    if ((!kFrames || muscle >= 0) && d.muscles[muscle].special) {
      if constexpr (!kFrames) {  // (one call less than through DynamicKinematics)
        if (d.muscles[muscle].one_cylinder) {
          return OneCylinderKinematics(d, ws, q, muscle, activation);
        }
      }
      // (a force model on a fixed path straight to its kernel: DynamicKinematics' frame
      // costs ~40 instructions)
      if (!d.muscles[muscle].dynamic) {
        return ForceKinematics<kFrames>(d, ws, q, muscle, activation, world_axes);
      }
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
}

// Locked coordinates are rigid in the statics: their columns of J and entries of tau are set
// to 0 and their S_p entry to a stiffness on the scale of K (the largest S_t or S_p entry, at
// least 1), so that K has an isolated diagonal there and dtheta is exactly 0 on them; the
// other entries of dtheta and W are those of the statics without the locked columns. The
// reported J and tau (ws.Jr, ws.tau) keep every column.
template <class W>
ISOWRENCH_NOINLINE WrenchResult SolveLocked(const FlatChain& d, W& ws,
                                            const StiffnessSet& stiffness,
                                            const SolveOptions& options) {
  const int S = ws.kStride;
  const int n = d.n;
  // Row-major, row stride S (as Data::Impl::Jr): on the stack for a small chain (zeroed each
  // time), in the workspace for a large one (zero from construction on past column n).
  alignas(32) double J_small[W::kLarge ? 1 : 6 * kSmallJoints] = {};
  double tau_small[W::kLarge ? 1 : kSmallJoints];
  double s_p_small[W::kLarge ? 1 : kSmallJoints];
  double* J = J_small;
  double* tau = tau_small;
  double* s_p = s_p_small;
  if constexpr (W::kLarge) {
    J = ws.locked_J.data();
    tau = ws.locked_tau.data();
    s_p = ws.s_p_copy.data();
  }
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

// A Data made for another model (or by Data(int)) runs this chain only when its buffers are
// big enough for it (WorkspaceSize::Holds); otherwise the evaluation would write past them.
ISOWRENCH_NOINLINE void CheckOtherWorkspace(const FlatChain& d, const Data::Impl& ws) {
  if (ws.size.Holds(d)) return;
  const std::string made_for = ws.model_name.empty()
                                   ? "Data(" + std::to_string(ws.m) + ") (a raw-matrix solve)"
                                   : "model '" + ws.model_name + "'";
  throw Error(
      "this Data was made for " + made_for + " (" + std::to_string(ws.m) + " coordinates, " +
      std::to_string(ws.size.joints) + " movable joints, " + std::to_string(ws.size.points) +
      " path points per muscle) and cannot evaluate model '" + d.name + "' (" +
      std::to_string(d.n) + " coordinates, " + std::to_string(d.m) + " movable joints, " +
      std::to_string(d.max_points) + " path points per muscle): make a Data(model) for each model");
}

// The workspace check of the kinematics entry points: one comparison for the Data made for this
// model (and its copies).
ISOWRENCH_INLINE void CheckWorkspace(const FlatChain& d, const Data::Impl& ws) {
  if (__builtin_expect(ws.chain_id != d.id, 0)) CheckOtherWorkspace(d, ws);
}

}  // namespace

ISOWRENCH_CLONES bool ComputeKinematics(const Model& model, Data& workspace,
                                        const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                                        double activation) {
  assert(q.size() == model.dof_count());
  const FlatChain& d = model.impl().flat;
  CheckWorkspace(d, workspace.impl());
  return WithShape(d.large, workspace.impl(), [&](auto& ws) ISOWRENCH_LAMBDA_INLINE {
    return AnyKinematics<false>(d, ws, q.data(), muscle, activation, false);
  });
}

bool ComputeKinematicsWithFrames(const FlatChain& chain, Data::Impl& workspace, const double* q,
                                 int muscle, double activation, bool world_axes) {
  CheckWorkspace(chain, workspace);
  return WithShape(chain.large, workspace, [&](auto& ws) {
    return AnyKinematics<true>(chain, ws, q, muscle, activation, world_axes);
  });
}

void SetPathPointOffsets(const Model& model, Data& data, int muscle,
                         const Eigen::Ref<const Eigen::Matrix3Xd>& offsets) {
  const FlatChain& d = model.impl().flat;
  Data::Impl& ws = data.impl();
  if (ws.chain_id != d.id) {
    throw Error("SetPathPointOffsets: this Data was made for " +
                (ws.model_name.empty() ? std::string("a raw-matrix solve")
                                       : "model '" + ws.model_name + "'") +
                ", not for model '" + d.name + "': make a Data(model)");
  }
  if (muscle < 0 || muscle >= static_cast<int>(d.muscles.size())) {
    throw Error("SetPathPointOffsets: muscle index " + std::to_string(muscle) +
                " is out of range for model '" + d.name + "' (" + std::to_string(d.muscles.size()) +
                " muscles)");
  }
  const FastMuscle& mu = d.muscles[static_cast<std::size_t>(muscle)];
  if (offsets.cols() != mu.path_points) {
    throw Error("SetPathPointOffsets: muscle '" + model.muscle(muscle).name + "' has " +
                std::to_string(mu.path_points) + " path points, got offsets for " +
                std::to_string(offsets.cols()));
  }
  if (!offsets.allFinite()) {
    throw Error("SetPathPointOffsets: muscle '" + model.muscle(muscle).name +
                "': a path point offset is not finite");
  }
  // The Data's copy of the muscle (made by the first call for it), its path points at the
  // model's positions plus the offsets. Offsets are in each point's link frame; the kernel
  // places points in the frame of the movable joint before them, fixed joints folded in
  // (FlatChain::links): turned into it.
  if (!ws.moved_muscle || ws.moved_chain != d.id || ws.moved_index != muscle) {
    ws.offset_muscle = -1;
    if (ws.moved_muscle) {
      *ws.moved_muscle = mu;
    } else {
      ws.moved_muscle = std::make_unique<FastMuscle>(mu);
    }
    const std::vector<PathPoint>& path = model.muscle(muscle).path;
    ws.offset_rotations.resize(path.size());
    for (std::size_t i = 0; i < path.size(); ++i)
      ws.offset_rotations[i] = d.links.at(path[i].link).offset.linear();
    ws.moved_chain = d.id;
    ws.moved_index = muscle;
  }
  for (int i = 0; i < mu.path_points; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    ws.moved_muscle->points[k].position =
        mu.points[k].position + ws.offset_rotations[k] * offsets.col(i);
  }
  ws.offset_muscle = muscle;
}

void ClearPathPointOffsets(Data& data) { data.impl().offset_muscle = -1; }  // (the copy stays)

const MuscleForceModel& ForceModelOf(const Model& model, int muscle) {
  const FlatChain& d = model.impl().flat;
  if (muscle < 0 || muscle >= static_cast<int>(d.muscles.size())) {
    throw Error("muscle index " + std::to_string(muscle) + " is out of range for model '" +
                model.name() + "' (" + std::to_string(d.muscles.size()) + " muscles)");
  }
  return d.muscles[static_cast<std::size_t>(muscle)].force_model;
}

MuscleForce MuscleForceAt(const Model& model, int muscle, double length, double activation) {
  ForceModelOf(model, muscle);  // (the index check)
  return MuscleForceOf(model.impl().flat.muscles[static_cast<std::size_t>(muscle)], length,
                       activation);
}

WrenchResult SolveStatics(const Model& model, Data& workspace, const StiffnessSet& stiffness,
                          const SolveOptions& options) {
  Data::Impl& ws = workspace.impl();
  const FlatChain& d = model.impl().flat;
  // (a Data of another size: "a size does not match", kInvalidInput)
  if (stiffness.s_p.size() != d.n || ws.m != d.n) return Invalid(ws);
  return WithShape(ws.size.large, ws, [&](auto& w) {
    if (d.any_locked) return SolveLocked(d, w, stiffness, options);
    return SolveDispatch(w, w.Jr.data(), stiffness.s_t.data(), stiffness.s_p.data(),
                         w.tau_data.data(), options);
  });
}

namespace {

// ComputeKinematics and SolveStatics in one function (one call, the solve's m-dispatch inlined),
// on a chain without couplings (kCoupled = false) or any chain (true). The result goes to
// `out`, which holds a default WrenchResult (invalid input) on entry.
template <bool kCoupled, class W>
ISOWRENCH_INLINE void EvaluateWith(const FlatChain& d, W& ws, const double* q, int muscle,
                                   const StiffnessSet& stiffness, double activation,
                                   const SolveOptions& options, WrenchResult& out) {
  bool valid;
  if constexpr (W::kLarge) {  // (the kinematics and the solve out of line, each compiled once)
    valid = AnyKinematics<false>(d, ws, q, muscle, activation, false);
  } else {
    const FastMuscle& mu = d.muscles[muscle];
    valid = !mu.special ? Kinematics<false, false, kCoupled>(d, ws, q, muscle, activation, false)
            : mu.one_cylinder ? OneCylinderKinematics(d, ws, q, muscle, activation)
                              : SpecialKinematics(d, ws, q, muscle, activation);
  }
  if (!valid || stiffness.s_p.size() != d.n) {
    Invalid(ws);
  } else if (d.any_locked) {
    out = SolveLocked(d, ws, stiffness, options);
  } else if constexpr (W::kLarge) {
    out = SolveDispatch(ws, ws.Jr.data(), stiffness.s_t.data(), stiffness.s_p.data(),
                        ws.tau_data.data(), options);
  } else {
    SolveAnyM(ws, ws.Jr.data(), stiffness.s_t.data(), stiffness.s_p.data(), ws.tau_data.data(),
              options, out);
  }
}

// Evaluate on a small chain without couplings (kCoupled = false), with them, or a large chain
// (W = LargeWorkspace): three functions, so that none shares another's registers and stack.
template <bool kCoupled, class W>
ISOWRENCH_CLONES ISOWRENCH_NOINLINE WrenchResult EvaluateChain(
    const Model& model, Data& workspace, const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
    const StiffnessSet& stiffness, double activation, const SolveOptions& options) {
  const FlatChain& d = model.impl().flat;
  CheckWorkspace(d, workspace.impl());
  W& ws = static_cast<W&>(workspace.impl());
  assert(q.size() == d.n && ws.m == d.n);
  WrenchResult out;  // every path returns this object (no copy of the result)
  EvaluateWith<kCoupled>(d, ws, q.data(), muscle, stiffness, activation, options, out);
  return out;
}

}  // namespace

namespace {

// An activation outside [0, 1] (or NaN): the error MuscleForceModel::Evaluate gives, naming the
// muscle and the value, for every force model (the constant one too). Out of line and cold.
[[noreturn]] ISOWRENCH_NOINLINE void ThrowActivation(const Model& model, int muscle,
                                                     double activation) {
  static_cast<void>(MuscleForceAt(model, muscle, 1.0, activation));  // throws
  throw Error("activation " + std::to_string(activation) + " is outside [0, 1]");
}

}  // namespace

ISOWRENCH_CLONES WrenchResult Evaluate(const Model& model, Data& workspace,
                                       const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                                       const StiffnessSet& stiffness, double activation,
                                       const SolveOptions& options) {
  // One test per call (false for NaN too): a constant-force muscle multiplies the activation
  // into the kernel and would scale the wrench by an invalid value silently.
  if (__builtin_expect(!(activation >= 0.0 && activation <= 1.0), 0))
    ThrowActivation(model, muscle, activation);
  const FlatChain& d = model.impl().flat;
  if (d.large) {
    return EvaluateChain<true, LargeWorkspace>(model, workspace, q, muscle, stiffness, activation,
                                               options);
  }
  return d.coupled ? EvaluateChain<true, SmallWorkspace>(model, workspace, q, muscle, stiffness,
                                                         activation, options)
                   : EvaluateChain<false, SmallWorkspace>(model, workspace, q, muscle, stiffness,
                                                          activation, options);
}

WrenchResult SolveStatics(Data& workspace, const Eigen::Ref<const Matrix6Xd>& J,
                          const Vector6d& s_t, const Eigen::Ref<const Eigen::VectorXd>& s_p,
                          const Eigen::Ref<const Eigen::VectorXd>& tau,
                          const SolveOptions& options) {
  Data::Impl& impl = workspace.impl();
  const int m = impl.m;
  if (J.cols() != m || s_p.size() != m || tau.size() != m || !J.allFinite()) return Invalid(impl);
  impl.SetJacobian(J);
  impl.tau = tau;
  return WithShape(impl.size.large, impl, [&](auto& ws) {
    using W = std::remove_reference_t<decltype(ws)>;
    double s_p_small[W::kLarge ? 1 : kSmallJoints];
    double* s_p_copy = s_p_small;
    if constexpr (W::kLarge) s_p_copy = ws.s_p_copy.data();
    for (int i = 0; i < m; ++i) s_p_copy[i] = s_p[i];
    return SolveDispatch(ws, ws.Jr.data(), s_t.data(), s_p_copy, ws.tau_data.data(), options);
  });
}

}  // namespace isowrench
