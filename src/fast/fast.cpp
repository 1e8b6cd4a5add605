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
#include <limits>
#include <map>
#include <string>

#include "fast/fast_impl.hpp"
#include "isowrench/error.hpp"
#include "model/model_impl.hpp"

namespace isowrench {
namespace {

// A path segment shorter than this has no direction (same rule as ComputeMuscleTorque).
constexpr double kMinSegmentLength = 1e-9;

// The hot functions are compiled twice, for x86-64-v3 (AVX2 + FMA: a multiply-add is one
// instruction, 4 doubles per register) and for the baseline; the loader picks the one the CPU
// runs (GNU ifunc). Other compilers/targets get the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ISOWRENCH_NO_CLONES)
#define ISOWRENCH_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ISOWRENCH_CLONES
#endif
#if defined(__GNUC__)
#define ISOWRENCH_INLINE inline __attribute__((always_inline))
#else
#define ISOWRENCH_INLINE inline
#endif


void SetAxisKind(FastJoint& joint) {
  const Eigen::Vector3d& a = joint.axis;
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    if (a[k1] == 0.0 && a[k2] == 0.0 && std::abs(a[k]) == 1.0) {
      joint.axis_kind = k;
      joint.axis_sign = a[k];
      return;
    }
  }
  joint.axis_kind = 3;
}

// sin and cos of one angle, to within an ulp or two, in about 50 instructions instead of the
// ~120 of libm's sincos (which also handles huge arguments exactly): Cody-Waite reduction by
// pi/2 with a three-part constant (exact products for |n| < 2^20), then fdlibm's
// __kernel_sin / __kernel_cos polynomials on [-pi/4, pi/4]. Angles beyond kMaxReduced fall
// back to std::sin/std::cos.
ISOWRENCH_INLINE void SinCos(double x, double* sin_x, double* cos_x) {
  constexpr double kMaxReduced = 1e5;  // rad; n = round(x 2/pi) < 2^17 keeps n * kPio2_1 exact
  if (!(std::abs(x) < kMaxReduced)) {
    *sin_x = std::sin(x);
    *cos_x = std::cos(x);
    return;
  }
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kPio2_1 = 1.57079632673412561417e+00;   // first 33 bits of pi/2
  constexpr double kPio2_2 = 6.07710050630396597660e-11;   // next 33 bits
  constexpr double kPio2_3 = 2.02226624871116645580e-21;   // next 33 bits
  constexpr double kRound = 6755399441055744.0;            // 1.5 * 2^52: round to nearest
  const double k = (x * kTwoOverPi + kRound) - kRound;
  const long n = static_cast<long>(k);
  const double r = ((x - k * kPio2_1) - k * kPio2_2) - k * kPio2_3;
  const double z = r * r;
  constexpr double S1 = -1.66666666666666324348e-01, S2 = 8.33333333332248946124e-03,
                   S3 = -1.98412698298579493134e-04, S4 = 2.75573137070700676789e-06,
                   S5 = -2.50507602534068634195e-08, S6 = 1.58969099521155010221e-10;
  constexpr double C1 = 4.16666666666666019037e-02, C2 = -1.38888888888741095749e-03,
                   C3 = 2.48015872894767294178e-05, C4 = -2.75573143513906633035e-07,
                   C5 = 2.08757232129817482790e-09, C6 = -1.13596475577881948265e-11;
  const double sin_r = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  const double cos_r = w + (((1.0 - w) - hz) + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6))))));
  // Quadrant n mod 4: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s).
  const bool swap = n & 1;
  const double sign_sin = (n & 2) ? -1.0 : 1.0;
  const double sign_cos = ((n + 1) & 2) ? -1.0 : 1.0;
  *sin_x = sign_sin * (swap ? cos_r : sin_r);
  *cos_x = sign_cos * (swap ? sin_r : cos_r);
}

// M <- M * Rot(axis, q) for a joint.
ISOWRENCH_INLINE void RotateFrame(const FastJoint& j, double q, Eigen::Matrix3d& M) {
  double c, s;
  SinCos(q, &s, &c);
  s *= j.axis_sign;
  switch (j.axis_kind) {
    case 0: {
      const Eigen::Vector3d m1 = M.col(1), m2 = M.col(2);
      M.col(1) = c * m1 + s * m2;
      M.col(2) = c * m2 - s * m1;
      break;
    }
    case 1: {
      const Eigen::Vector3d m0 = M.col(0), m2 = M.col(2);
      M.col(0) = c * m0 - s * m2;
      M.col(2) = s * m0 + c * m2;
      break;
    }
    case 2: {
      const Eigen::Vector3d m0 = M.col(0), m1 = M.col(1);
      M.col(0) = c * m0 + s * m1;
      M.col(1) = c * m1 - s * m0;
      break;
    }
    default: {
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(q, j.axis).toRotationMatrix();
      M = (M * rot).eval();
      break;
    }
  }
}

// Full unrolling of the statics loops when m is a compile-time constant (N > 0): the 8-dof
// kernel's K, Cholesky and solves become straight-line code the compiler keeps in registers.
#if defined(__GNUC__) && !defined(__clang__)
#define ISOWRENCH_UNROLL _Pragma("GCC unroll 16")
#elif defined(__clang__)
#define ISOWRENCH_UNROLL _Pragma("unroll")
#else
#define ISOWRENCH_UNROLL
#endif


// The eigen-solve used when the Cholesky pivots say K is (nearly) singular: the same rank and
// excitation decisions as SolveStatics, on the workspace's fixed-size buffers.
FastWrench SolveByEigen(FastWorkspace::Impl& ws, int m, const double* J, const double* s_t,
                        const double* tau, const FastOptions& options) {
  FastWrench out;
  FastJointMatrix& K = ws.K_full;
  K.resize(m, m);
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j <= i; ++j) K(i, j) = K(j, i) = ws.K[i * kFastMaxDofs + j];
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
ISOWRENCH_INLINE bool ValidSolveInput(int m, const double* s_t, const double* s_p, const double* tau) {
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

FastWrench Invalid(FastWorkspace::Impl& ws) {
  ws.dtheta.setZero(ws.m);
  ws.self_motion.resize(ws.m, 0);
  return FastWrench{};
}

// K = J^T S_t J + S_p, Cholesky, two triangular solves, W = S_t J dtheta. N > 0 fixes m at
// compile time (loops unroll); N = 0 uses the runtime m. J is 6 x m column-major.
template <int N>
ISOWRENCH_INLINE FastWrench SolveKernel(FastWorkspace::Impl& ws, int m_runtime, const double* J, const double* s_t,
                       const double* s_p, const double* tau, const FastOptions& options) {
  constexpr int S = kFastMaxDofs;
  const int m = N > 0 ? N : std::min(m_runtime, S);  // workspaces never exceed S
  if (!ValidSolveInput(m, s_t, s_p, tau)) return Invalid(ws);
  double* K = ws.K;
  double max_diag = 0.0;
  ISOWRENCH_UNROLL
  for (int i = 0; i < m; ++i) {
    double sj[6];
    ISOWRENCH_UNROLL
    for (int r = 0; r < 6; ++r) sj[r] = s_t[r] * J[i * 6 + r];
    ISOWRENCH_UNROLL
    for (int j = 0; j <= i; ++j) {
      double sum = 0.0;
      ISOWRENCH_UNROLL
      for (int r = 0; r < 6; ++r) sum += sj[r] * J[j * 6 + r];
      K[i * S + j] = sum;
    }
    K[i * S + i] += s_p[i];
    max_diag = std::max(max_diag, K[i * S + i]);
  }
  // Cholesky K = L L^T, accepted only with every pivot clearly positive.
  const double pivot_floor = options.cholesky_pivot_tolerance * max_diag;
  // Factor and reciprocal diagonal live in locals: once unrolled they stay in registers.
  double L[S * S];
  double inv_diag[S];
  if (!(max_diag > 0.0)) return SolveByEigen(ws, m, J, s_t, tau, options);
  ISOWRENCH_UNROLL
  for (int j = 0; j < m; ++j) {
    double d = K[j * S + j];
    ISOWRENCH_UNROLL
    for (int k = 0; k < j; ++k) d -= L[j * S + k] * L[j * S + k];
    if (!(d > pivot_floor)) return SolveByEigen(ws, m, J, s_t, tau, options);
    const double l = std::sqrt(d);
    const double inv = 1.0 / l;
    L[j * S + j] = l;
    inv_diag[j] = inv;
    ISOWRENCH_UNROLL
    for (int i = j + 1; i < m; ++i) {
      double v = K[i * S + j];
      ISOWRENCH_UNROLL
      for (int k = 0; k < j; ++k) v -= L[i * S + k] * L[j * S + k];
      L[i * S + j] = v * inv;
    }
  }
  double y[S];
  ISOWRENCH_UNROLL
  for (int i = 0; i < m; ++i) {
    double v = tau[i];
    ISOWRENCH_UNROLL
    for (int k = 0; k < i; ++k) v -= L[i * S + k] * y[k];
    y[i] = v * inv_diag[i];
  }
  ws.dtheta.resize(m);
  double* x = ws.dtheta.data();
  ISOWRENCH_UNROLL
  for (int i = m - 1; i >= 0; --i) {
    double v = y[i];
    ISOWRENCH_UNROLL
    for (int k = i + 1; k < m; ++k) v -= L[k * S + i] * x[k];
    x[i] = v * inv_diag[i];
  }
  FastWrench out;
  ISOWRENCH_UNROLL
  for (int r = 0; r < 6; ++r) {
    double v = 0.0;
    ISOWRENCH_UNROLL
    for (int j = 0; j < m; ++j) v += J[j * 6 + r] * x[j];
    out.wrench[r] = s_t[r] * v;
  }
  out.status = StaticsStatus::kOk;
  ws.self_motion.resize(m, 0);
  return out;
}

ISOWRENCH_CLONES FastWrench SolveDispatch(FastWorkspace::Impl& ws, const double* J, const double* s_t,
                         const double* s_p, const double* tau, const FastOptions& options) {
  switch (ws.m) {
    case 1: return SolveKernel<1>(ws, 1, J, s_t, s_p, tau, options);
    case 2: return SolveKernel<2>(ws, 2, J, s_t, s_p, tau, options);
    case 3: return SolveKernel<3>(ws, 3, J, s_t, s_p, tau, options);
    case 4: return SolveKernel<4>(ws, 4, J, s_t, s_p, tau, options);
    case 5: return SolveKernel<5>(ws, 5, J, s_t, s_p, tau, options);
    case 6: return SolveKernel<6>(ws, 6, J, s_t, s_p, tau, options);
    case 7: return SolveKernel<7>(ws, 7, J, s_t, s_p, tau, options);
    case 8: return SolveKernel<8>(ws, 8, J, s_t, s_p, tau, options);
    case 9: return SolveKernel<9>(ws, 9, J, s_t, s_p, tau, options);
    case 10: return SolveKernel<10>(ws, 10, J, s_t, s_p, tau, options);
    default: return SolveKernel<0>(ws, ws.m, J, s_t, s_p, tau, options);
  }
}

}  // namespace

// ---- CompiledModel --------------------------------------------------------------------------

CompiledModel::CompiledModel(const Model& model) {
  auto data = std::make_shared<Data>(model);
  const LimbDescription& d = model.description();
  data->m = model.dof_count();
  if (data->m > kFastMaxDofs) {
    throw Error("model '" + model.name() + "' has " + std::to_string(data->m) +
                " movable joints; the fast path handles at most " + std::to_string(kFastMaxDofs));
  }
  // Walk the chain, folding fixed joints into the next movable joint (or the endpoint).
  std::map<std::string, std::pair<int, Eigen::Isometry3d>> link_frames;
  Eigen::Isometry3d since_last = Eigen::Isometry3d::Identity();
  int frame = -1;
  link_frames[d.root_link] = {-1, since_last};
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed) {
      since_last = since_last * j.origin;
      link_frames[j.child_link] = {frame, since_last};
      continue;
    }
    const Eigen::Isometry3d origin = since_last * j.origin;
    FastJoint fj;
    fj.origin_rotation = origin.linear();
    fj.origin_translation = origin.translation();
    fj.rotation_is_identity = fj.origin_rotation == Eigen::Matrix3d::Identity();
    fj.translation_is_zero = fj.origin_translation == Eigen::Vector3d::Zero();
    fj.axis = j.axis;
    fj.revolute = j.type == JointType::kRevolute;
    SetAxisKind(fj);
    data->joints.push_back(fj);
    ++frame;
    since_last = Eigen::Isometry3d::Identity();
    link_frames[j.child_link] = {frame, since_last};
  }
  assert(frame + 1 == data->m);
  const TransducerSpec& t = d.transducer;
  data->endpoint = since_last * t.endpoint;
  data->transducer_in_world = t.axes_in_world;
  data->transducer_rotation = t.axes_in_world ? t.rotation : Eigen::Matrix3d(since_last.linear() * t.rotation);
  data->transducer_identity = t.axes_in_world && t.rotation == Eigen::Matrix3d::Identity();

  for (int i = 0; i < model.muscle_count(); ++i) {
    const MuscleSpec& spec = model.muscle(i);
    if (static_cast<int>(spec.path.size()) > kFastMaxPathPoints) {
      throw Error("muscle '" + spec.name + "' has " + std::to_string(spec.path.size()) +
                  " path points; the fast path handles at most " + std::to_string(kFastMaxPathPoints));
    }
    FastMuscle muscle;
    muscle.max_force = spec.max_force;
    for (const PathPoint& p : spec.path) {
      const auto& [f, offset] = link_frames.at(p.link);
      muscle.points.push_back({f, offset * p.position});
    }
    for (int f = data->m - 1; f >= 0; --f) {
      for (size_t k = 0; k < muscle.points.size(); ++k) {
        if (muscle.points[k].frame == f) muscle.sweep_order.push_back(static_cast<int>(k));
      }
    }
    data->muscles.push_back(std::move(muscle));
  }
  data->stiffness.s_t = t.stiffness;
  for (int i = 0; i < 6; ++i) {
    if (t.released[i]) data->stiffness.s_t[i] = 0.0;
  }
  data->stiffness.s_p = model.joint_stiffness();
  data_ = data;
}

int CompiledModel::dof_count() const { return data_->m; }
int CompiledModel::muscle_count() const { return static_cast<int>(data_->muscles.size()); }
bool CompiledModel::revolute(int column) const { return data_->joints.at(column).revolute; }
StiffnessSet CompiledModel::model_stiffness() const { return data_->stiffness; }
const Model& CompiledModel::model() const { return data_->model; }

// ---- FastWorkspace --------------------------------------------------------------------------

FastWorkspace::Impl::Impl(int dofs) : m(dofs), eigen(dofs) {
  J.setZero(6, m);
  dL.setZero(m);
  tau.setZero(m);
  dtheta.setZero(m);
  K_full.setZero(m, m);
  self_motion.resize(m, 0);
  for (double& v : K) v = 0.0;
}

FastWorkspace::FastWorkspace(const CompiledModel& model)
    : impl_(std::make_unique<Impl>(model.dof_count())) {}

FastWorkspace::FastWorkspace(int dof_count) {
  if (dof_count < 1 || dof_count > kFastMaxDofs) {
    throw Error("FastWorkspace: dof count " + std::to_string(dof_count) + " is not in [1, " +
                std::to_string(kFastMaxDofs) + "]");
  }
  impl_ = std::make_unique<Impl>(dof_count);
}

FastWorkspace::~FastWorkspace() = default;
FastWorkspace::FastWorkspace(FastWorkspace&&) noexcept = default;
FastWorkspace& FastWorkspace::operator=(FastWorkspace&&) noexcept = default;

const FastJacobian& FastWorkspace::jacobian() const { return impl_->J; }
const FastJointVector& FastWorkspace::tau() const { return impl_->tau; }
const FastJointVector& FastWorkspace::muscle_length_gradient() const { return impl_->dL; }
double FastWorkspace::muscle_length() const { return impl_->length; }
const Eigen::Vector3d& FastWorkspace::endpoint_position() const { return impl_->endpoint; }
const Eigen::Matrix3d& FastWorkspace::transducer_rotation() const { return impl_->R_W_T; }
const FastJointVector& FastWorkspace::dtheta() const { return impl_->dtheta; }
const FastJointMatrix& FastWorkspace::self_motion() const { return impl_->self_motion; }

// ---- Evaluation -----------------------------------------------------------------------------

ISOWRENCH_CLONES bool ComputeFastKinematics(const CompiledModel& model, FastWorkspace& workspace,
                           const Eigen::Ref<const Eigen::VectorXd>& q, int muscle, double activation) {
  const CompiledModel::Data& d = model.data();
  FastWorkspace::Impl& ws = workspace.impl();
  const int m = d.m;
  assert(q.size() == m && ws.m == m);
  assert(muscle >= 0 && muscle < static_cast<int>(d.muscles.size()));

  // Forward kinematics along the chain.
  for (int k = 0; k < m; ++k) {
    const FastJoint& j = d.joints[k];
    Eigen::Matrix3d& M = ws.R[k];
    Eigen::Vector3d joint_origin;
    if (k == 0) {
      M = j.origin_rotation;
      joint_origin = j.origin_translation;
    } else {
      const Eigen::Matrix3d& R = ws.R[k - 1];
      joint_origin = j.translation_is_zero ? ws.origin[k - 1]
                                           : Eigen::Vector3d(ws.origin[k - 1] + R * j.origin_translation);
      if (j.rotation_is_identity) {
        M = R;
      } else {
        M.noalias() = R * j.origin_rotation;
      }
    }
    Eigen::Vector3d& z = ws.axis[k];
    if (j.axis_kind < 3) {
      z = j.axis_sign * M.col(j.axis_kind);
    } else {
      z.noalias() = M * j.axis;
    }
    if (j.revolute) {
      RotateFrame(j, q[k], M);
      ws.origin[k] = joint_origin;
    } else {
      ws.origin[k] = joint_origin + z * q[k];
    }
  }
  const Eigen::Matrix3d& R_last = ws.R[m - 1];
  ws.endpoint.noalias() = R_last * d.endpoint;
  ws.endpoint += ws.origin[m - 1];

  // Endpoint Jacobian in world axes, then in transducer axes.
  ws.J.resize(6, m);
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d& z = ws.axis[k];
    if (d.joints[k].revolute) {
      ws.J.col(k).head<3>() = z.cross(ws.endpoint - ws.origin[k]);
      ws.J.col(k).tail<3>() = z;
    } else {
      ws.J.col(k).head<3>() = z;
      ws.J.col(k).tail<3>().setZero();
    }
  }
  if (d.transducer_identity) {
    ws.R_W_T.setIdentity();
  } else {
    if (d.transducer_in_world) {
      ws.R_W_T = d.transducer_rotation;
    } else {
      ws.R_W_T.noalias() = R_last * d.transducer_rotation;
    }
    for (int k = 0; k < m; ++k) {
      const Eigen::Vector3d v = ws.R_W_T.transpose() * ws.J.col(k).head<3>();
      const Eigen::Vector3d w = ws.R_W_T.transpose() * ws.J.col(k).tail<3>();
      ws.J.col(k).head<3>() = v;
      ws.J.col(k).tail<3>() = w;
    }
  }

  // Muscle: point positions, unit segment directions, pulls, then the backward sweep.
  const FastMuscle& mu = d.muscles[muscle];
  const int n = static_cast<int>(mu.points.size());
  for (int i = 0; i < n; ++i) {
    const FastPathPoint& p = mu.points[i];
    if (p.frame < 0) {
      ws.points[i] = p.position;
    } else {
      ws.points[i].noalias() = ws.R[p.frame] * p.position;
      ws.points[i] += ws.origin[p.frame];
    }
  }
  ws.length = 0.0;
  ws.dL.resize(m);  // every entry is assigned by the sweep below
  ws.tau.resize(m);
  Eigen::Vector3d u_before = Eigen::Vector3d::Zero();  // u_{i-1}; zero before the origin
  for (int i = 1; i < n; ++i) {
    const Eigen::Vector3d segment = ws.points[i] - ws.points[i - 1];
    const double length = segment.norm();
    if (!(length >= kMinSegmentLength)) {
      ws.dL.setZero();
      ws.tau.setZero();
      return false;
    }
    const Eigen::Vector3d u = segment / length;
    ws.length += length;
    ws.pulls[i - 1] = u_before - u;
    u_before = u;
  }
  ws.pulls[n - 1] = u_before;
  Eigen::Vector3d pull_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment_sum = Eigen::Vector3d::Zero();
  const int sweep_count = static_cast<int>(mu.sweep_order.size());
  int next = 0;
  for (int k = m - 1; k >= 0; --k) {
    while (next < sweep_count && mu.points[mu.sweep_order[next]].frame == k) {
      const int i = mu.sweep_order[next++];
      pull_sum += ws.pulls[i];
      moment_sum += ws.points[i].cross(ws.pulls[i]);
    }
    const Eigen::Vector3d& z = ws.axis[k];
    ws.dL[k] = d.joints[k].revolute ? z.dot(moment_sum - ws.origin[k].cross(pull_sum)) : z.dot(pull_sum);
  }
  const double force = activation * mu.max_force;
  ws.tau = -force * ws.dL;
  return true;
}

FastWrench SolveFastStatics(const CompiledModel& model, FastWorkspace& workspace,
                            const StiffnessSet& stiffness, const FastOptions& options) {
  FastWorkspace::Impl& ws = workspace.impl();
  const int m = model.dof_count();
  assert(ws.m == m);
  if (stiffness.s_p.size() != m) return Invalid(ws);
  return SolveDispatch(ws, ws.J.data(), stiffness.s_t.data(), stiffness.s_p.data(), ws.tau.data(),
                       options);
}

FastWrench EvaluateFast(const CompiledModel& model, FastWorkspace& ws,
                        const Eigen::Ref<const Eigen::VectorXd>& q, int muscle,
                        const StiffnessSet& stiffness, double activation, const FastOptions& options) {
  if (!ComputeFastKinematics(model, ws, q, muscle, activation)) return Invalid(ws.impl());
  return SolveFastStatics(model, ws, stiffness, options);
}

FastWrench SolveStaticsFast(FastWorkspace& workspace, const Eigen::Ref<const Matrix6Xd>& J,
                            const Vector6d& s_t, const Eigen::Ref<const Eigen::VectorXd>& s_p,
                            const Eigen::Ref<const Eigen::VectorXd>& tau, const FastOptions& options) {
  FastWorkspace::Impl& ws = workspace.impl();
  const int m = ws.m;
  if (J.cols() != m || s_p.size() != m || tau.size() != m || !J.allFinite()) return Invalid(ws);
  ws.J = J;
  ws.tau = tau;
  double s_p_copy[kFastMaxDofs];
  for (int i = 0; i < m; ++i) s_p_copy[i] = s_p[i];
  return SolveDispatch(ws, ws.J.data(), s_t.data(), s_p_copy, ws.tau.data(), options);
}

}  // namespace isowrench
