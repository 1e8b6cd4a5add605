// Nonlinear equilibrium of the restrained limb (forward kinematics updated), by Newton's method
// on the potential U(theta) = 1/2 e^T S_t e + 1/2 dtheta^T S_p dtheta + F (L(theta) - L(theta0)).

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

#include "diagnostics/scaling.hpp"
#include "isowrench/diagnostics.hpp"
#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "util/eigen_instantiations.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d h;
  h << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return h;
}

// Rotation vector of R (log map), accurate for small angles (quaternion half-angle form).
Eigen::Vector3d LogMap(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond quat(R);
  quat.normalize();
  if (quat.w() < 0) quat.coeffs() = -quat.coeffs();
  const double s = quat.vec().norm();
  if (s == 0.0) return Eigen::Vector3d::Zero();
  const double angle = 2.0 * std::atan2(s, quat.w());
  return quat.vec() * (angle / s);
}

// Inverse of the left Jacobian of SO(3): d phi = J_l^-1(phi) omega when R -> exp([omega]) R.
Eigen::Matrix3d InverseLeftJacobian(const Eigen::Vector3d& phi) {
  const double t = phi.norm();
  const Eigen::Matrix3d P = Hat(phi);
  // Series below 1e-4 rad: the closed form loses digits to cancellation there; the next term
  // (t^4 / 30240) is below 1e-20.
  double c = t < 1e-4 ? 1.0 / 12.0 + t * t / 720.0
                      : 1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
  return Eigen::Matrix3d::Identity() - 0.5 * P + c * P * P;
}

struct Problem {
  const Model& model;
  Data ws;
  Eigen::VectorXd q0;
  int muscle_index;
  double activation;
  Eigen::Isometry3d X0;
  Eigen::Matrix3d R_T;  // transducer axes, fixed at the initial pose
  Vector6d s_t;         // released rows 0
  Eigen::VectorXd s_p;
  double L0 = 0.0;
  double F0 = 0.0;  // the force stage at L0 (N)

  Problem(const Model& m, const Eigen::VectorXd& q, int muscle, double act)
      : model(m), ws(m), q0(q), muscle_index(muscle), activation(act) {
    X0 = EndpointPose(model, ws, q0);
    R_T = TransducerRotation(model, ws, q0);
    const StaticsProblem problem(model);  // the effective S_t (released rows 0) and S_p
    s_t = problem.stiffness().s_t;
    s_p = problem.stiffness().s_p;
    const MuscleTorque t0 = ComputeMuscleTorque(model, ws, q0, muscle_index, activation);
    L0 = t0.length;
    F0 = t0.force;
  }

  Eigen::VectorXd Gradient(const Eigen::VectorXd& theta, double* U, Vector6d* W) {
    Eigen::Isometry3d X = EndpointPose(model, ws, theta);
    Matrix6Xd Jw = EndpointJacobianWorld(model, ws, theta);
    MuscleTorque mt = ComputeMuscleTorque(model, ws, theta, muscle_index, activation);
    const Eigen::Vector3d phi = LogMap(X.linear() * X0.linear().transpose());
    Vector6d e;
    e.head<3>() = R_T.transpose() * (X.translation() - X0.translation());
    e.tail<3>() = R_T.transpose() * phi;
    Matrix6Xd Je(6, Jw.cols());
    Je.topRows<3>() = R_T.transpose() * Jw.topRows<3>();
    Je.bottomRows<3>() = R_T.transpose() * InverseLeftJacobian(phi) * Jw.bottomRows<3>();
    const Vector6d force = s_t.cwiseProduct(e);
    const Eigen::VectorXd d = theta - q0;
    // The muscle's potential: the integral of F(L) from L0 (trapezoid: exact for the constant
    // model, O(dL^3) for a force model over the nanometre-scale deflections here).
    if (U) {
      *U = 0.5 * e.dot(force) + 0.5 * d.dot(s_p.cwiseProduct(d)) +
           0.5 * (F0 + mt.force) * (mt.length - L0);
    }
    if (W) *W = force;
    return Je.transpose() * force + s_p.cwiseProduct(d) - mt.tau;
  }
};

}  // namespace

const char* LargeDeflectionStatusName(LargeDeflectionStatus s) {
  switch (s) {
    case LargeDeflectionStatus::kConverged: return "converged";
    case LargeDeflectionStatus::kUnstable: return "unstable";
    case LargeDeflectionStatus::kNotConverged: return "not converged";
    case LargeDeflectionStatus::kFailed: return "failed";
  }
  return "?";
}

Eigen::VectorXd LargeDeflectionGradient(const Model& model, const Eigen::VectorXd& q0,
                                        const Eigen::VectorXd& theta, int muscle_index,
                                        double activation, double* potential, Vector6d* wrench) {
  ValidatePosture(model, q0);
  ValidatePosture(model, theta);
  Problem p(model, q0, muscle_index, activation);
  return p.Gradient(theta, potential, wrench);
}

LargeDeflectionResult SolveLargeDeflection(const Model& model, const Eigen::VectorXd& q,
                                           const std::string& muscle, double activation,
                                           const LargeDeflectionOptions& options) {
  const int muscle_index = model.MuscleIndex(muscle);
  ValidatePosture(model, q);
  LargeDeflectionResult r;
  const int m = model.dof_count();
  if (m == 0) {
    r.status = LargeDeflectionStatus::kFailed;
    r.message = "the model has no movable joints";
    return r;
  }
  // The unknowns are the columns of K: locked coordinates stay at q (StaticsProblem).
  const StaticsProblem problem(model);
  const std::vector<int>& columns = problem.columns();
  const int n = static_cast<int>(columns.size());
  const double Ls = problem.leg_length() > 0 ? problem.leg_length() : 1.0;
  // Linear answer for comparison.
  WrenchEvaluation lin = EvaluateWrench(model, q, muscle, activation);
  r.dtheta_linear = lin.statics.dtheta;
  r.wrench_linear = lin.statics.wrench;
  r.displacement = r.dtheta_linear.cwiseAbs().maxCoeff();
  r.dtheta_nonlinear = Eigen::VectorXd::Zero(m);
  if (n == 0) {
    r.status = LargeDeflectionStatus::kFailed;
    r.message = "every coordinate is locked: nothing moves";
    return r;
  }

  // Per-unknown scale: 1 for revolute (rad), L for prismatic (m).
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  for (int i = 0; i < n; ++i) {
    if (model.joint(columns[static_cast<size_t>(i)]).type == JointType::kPrismatic) scale[i] = Ls;
  }
  // theta = q + the unknowns on the columns of K; the gradient on them.
  auto posture = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd t = q;
    for (int i = 0; i < n; ++i) t[columns[static_cast<size_t>(i)]] += x[i];
    return t;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd theta = q;
  Vector6d W = Vector6d::Zero();
  try {
    Problem p(model, q, muscle_index, activation);
    const double tau_norm = std::max(problem.Reduce(lin.tau).cwiseAbs().maxCoeff(), 1e-300);
    auto gradient = [&](const Eigen::VectorXd& y, double* U_out, Vector6d* W_out) {
      return problem.Reduce(p.Gradient(posture(y), U_out, W_out));
    };
    double U = 0.0;
    Eigen::VectorXd g = gradient(x, &U, &W);
    Eigen::MatrixXd H(n, n);
    double previous_step = INFINITY;
    bool converged = false;
    bool failed = false;
    for (r.iterations = 0; r.iterations < options.max_iterations; ++r.iterations) {
      if (g.cwiseAbs().maxCoeff() <= options.gradient_tolerance * tau_norm) {
        converged = true;
        break;
      }
      // Hessian by central differences of the analytic gradient (it only sets the step; the
      // solution is where the analytic gradient vanishes).
      for (int c = 0; c < n; ++c) {
        const double h = 1e-6 * scale[c];
        Eigen::VectorXd tp = x, tm = x;
        tp[c] += h;
        tm[c] -= h;
        H.col(c) = (gradient(tp, nullptr, nullptr) - gradient(tm, nullptr, nullptr)) / (2 * h);
      }
      H = 0.5 * (H + H.transpose()).eval();
      // Levenberg damping until H + mu I is positive definite.
      double mu = 0.0;
      const double h_scale = std::max(H.diagonal().cwiseAbs().maxCoeff(), 1e-300);
      Eigen::VectorXd step;
      for (int attempt = 0; attempt < 60; ++attempt) {
        Eigen::MatrixXd Hd = H;
        Hd.diagonal().array() += mu;
        Eigen::LLT<Eigen::MatrixXd> llt(Hd);
        if (llt.info() == Eigen::Success) {
          step = -llt.solve(g);
          break;
        }
        mu = mu == 0.0 ? 1e-10 * h_scale : mu * 10;
      }
      if (step.size() != n || !step.allFinite()) {
        r.message = "no descent direction (the Hessian could not be made positive definite)";
        break;
      }
      // Limit wild steps (large-deflection cases start far from equilibrium).
      const double largest = step.cwiseQuotient(scale).cwiseAbs().maxCoeff();
      if (largest > options.max_step) step *= options.max_step / largest;
      const double dtheta_size = x.cwiseQuotient(scale).cwiseAbs().maxCoeff();
      const double step_size = step.cwiseQuotient(scale).cwiseAbs().maxCoeff();
      // Backtracking on U (Armijo). Near the solution, U differences fall below rounding;
      // a step a millionth of the displacement is then taken whole.
      double alpha = 1.0, U_new = U;
      Vector6d W_new;
      Eigen::VectorXd g_new;
      bool accepted = false;
      std::string broken;
      for (int k = 0; k < 40; ++k) {
        Eigen::VectorXd trial = x + alpha * step;
        try {
          g_new = gradient(trial, &U_new, &W_new);
        } catch (const Error& e) {
          // The trial posture is degenerate (e.g. a muscle of zero length): shorten the step.
          broken = e.what();
          alpha *= 0.5;
          continue;
        }
        if (U_new <= U + 1e-4 * alpha * g.dot(step) || step_size <= 1e-6 * dtheta_size) {
          accepted = true;
          x = trial;
          theta = posture(x);
          break;
        }
        alpha *= 0.5;
      }
      if (!accepted) {
        r.message =
            broken.empty()
                ? "line search failed: no decrease of the potential along the Newton step"
                : "no equilibrium near the posture: the limb is pulled until the geometry breaks "
                  "down (" +
                      broken + ")";
        failed = !broken.empty();
        break;
      }
      U = U_new;
      W = W_new;
      g = g_new;
      const double taken = alpha * step_size;
      // Step-based stops are trusted only where the gradient is already near its rounding
      // floor; elsewhere (e.g. at a kink of the potential) a stalled step is not a solution.
      constexpr double kStallGradient = 1e-6;
      const bool small_gradient = g.cwiseAbs().maxCoeff() <= kStallGradient * tau_norm;
      if (small_gradient && taken <= options.step_tolerance * std::max(dtheta_size, 1e-300)) {
        converged = true;
        ++r.iterations;
        break;
      }
      // Rounding floor: the quadratic phase has ended when steps stop shrinking.
      if (small_gradient && taken <= 1e-7 * dtheta_size && taken > 0.5 * previous_step) {
        converged = true;
        ++r.iterations;
        break;
      }
      previous_step = taken;
    }
    r.gradient_norm = g.cwiseAbs().maxCoeff();
    r.dtheta_nonlinear = theta - q;
    r.wrench_nonlinear = W;
    if (!converged) {
      r.status = failed ? LargeDeflectionStatus::kFailed : LargeDeflectionStatus::kNotConverged;
      if (r.message.empty())
        r.message = "no convergence in " + std::to_string(options.max_iterations) + " iterations";
    } else {
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
      const bool stable = r.iterations == 0 || eig.eigenvalues()[0] > 0;
      r.status = stable ? LargeDeflectionStatus::kConverged : LargeDeflectionStatus::kUnstable;
      r.message = std::string(stable ? "stable equilibrium"
                                     : "stationary point with a non-positive Hessian "
                                       "eigenvalue (not a stable equilibrium)") +
                  " after " + std::to_string(r.iterations) +
                  " Newton iterations, |grad U| = " + util::FormatNumber(r.gradient_norm, 3);
    }
  } catch (const Error& e) {
    r.status = LargeDeflectionStatus::kFailed;
    r.message = std::string("the geometry broke down during the iterations: ") + e.what();
    r.dtheta_nonlinear = theta - q;
    r.wrench_nonlinear = W;
  }
  r.dtheta_difference = (r.dtheta_nonlinear - r.dtheta_linear).cwiseAbs().maxCoeff();
  const double w_norm = diagnostics::ScaledWrenchNorm(r.wrench_linear, Ls);
  r.wrench_relative_difference =
      w_norm > 0 ? diagnostics::ScaledWrenchNorm(r.wrench_nonlinear - r.wrench_linear, Ls) / w_norm
                 : 0.0;
  if (!lin.statics.ok()) {
    r.message += "; the linear model has no unique answer (" +
                 std::string(StatusName(lin.statics.status)) + ")";
  }
  return r;
}

}  // namespace isowrench
