// dW/dlog(k) for every stiffness, analytically: K dtheta = tau, W = S_t J dtheta.
// For a diagonal stiffness entry k with dK/dk = A (and dS_t/dk = B for transducer entries):
//   d dtheta = -K^+ A dtheta dk,   dW = (B J dtheta + S_t J d dtheta) dk,
// and dW/dlog k = k dW/dk.

#include <Eigen/Eigenvalues>
#include <cmath>

#include "diagnostics/scaling.hpp"
#include "isowrench/diagnostics.hpp"
#include "util/eigen_instantiations.hpp"
#include "util/text.hpp"

namespace isowrench {

SensitivityResult ComputeStiffnessSensitivity(const Model& model, const WrenchEvaluation& e,
                                              double length_scale, double rank_tolerance) {
  SensitivityResult out;
  if (!e.statics.ok()) {
    out.message = std::string("no unique wrench (") + StatusName(e.statics.status) +
                  "): " + e.statics.message;
    return out;
  }
  if (e.jacobian.cols() != model.dof_count() || e.tau.size() != model.dof_count() ||
      e.s_p.size() != model.dof_count()) {
    out.message = "the evaluation does not belong to this model (column counts differ)";
    return out;
  }
  // The columns of K (locked coordinates are rigid: no column, and their stiffness changes
  // nothing), with the evaluation's compliances.
  StiffnessSet stiffness;
  stiffness.s_t = e.s_t;
  stiffness.s_p = e.s_p;
  const StaticsProblem problem(model, stiffness);
  const Matrix6Xd J = problem.Reduce(e.jacobian);
  const Eigen::VectorXd s_p = problem.reduced_s_p();
  const Eigen::VectorXd tau = problem.Reduce(e.tau);
  const Eigen::Index m = J.cols();
  if (m == 0) {
    out.message = "every coordinate is locked: no stiffness to vary";
    return out;
  }
  double L = length_scale > 0 && std::isfinite(length_scale) ? length_scale : problem.leg_length();
  if (!(L > 0)) L = 1.0;

  Eigen::MatrixXd K = J.transpose() * e.s_t.asDiagonal() * J;
  K.diagonal() += s_p;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const Eigen::MatrixXd& V = eig.eigenvectors();
  const double threshold = rank_tolerance * std::max(lambda[m - 1], 0.0);
  auto K_pinv = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      if (lambda[i] > threshold && lambda[i] > 0) y += V.col(i) * (V.col(i).dot(x) / lambda[i]);
    }
    return y;
  };
  const Eigen::VectorXd dtheta = K_pinv(tau);
  const Vector6d Jd = J * dtheta;
  const Vector6d W = e.s_t.cwiseProduct(Jd);
  const double w_norm = diagnostics::ScaledWrenchNorm(W, L);

  auto add = [&](std::string parameter, std::string kind, double k, std::string unit,
                 const Vector6d& dW) {
    StiffnessSensitivity s;
    s.parameter = std::move(parameter);
    s.kind = std::move(kind);
    s.stiffness = k;
    s.unit = std::move(unit);
    s.dW_dlogk = dW;
    s.relative = w_norm > 0 ? diagnostics::ScaledWrenchNorm(dW, L) / w_norm : 0.0;
    out.entries.push_back(s);
  };

  for (int i = 0; i < 6; ++i) {
    const double k = e.s_t[i];
    if (!(k > 0)) continue;  // released or zero: d/dlog k = k d/dk = 0
    // A = k J_i^T J_i, B = k e_i e_i^T.
    Eigen::VectorXd d_dtheta = -K_pinv(J.row(i).transpose() * (k * Jd[i]));
    Vector6d dW = e.s_t.cwiseProduct(J * d_dtheta);
    dW[i] += k * Jd[i];
    add(std::string("S_t ") + DofName(i), "transducer", k, i < 3 ? "N/m" : "N·m/rad", dW);
  }
  Eigen::VectorXd base_sum = Eigen::VectorXd::Zero(m);
  bool any_base = false;
  double base_k = 0.0;
  for (Eigen::Index j = 0; j < m; ++j) {
    const double k = s_p[j];
    if (!(k > 0)) continue;
    Eigen::VectorXd a = Eigen::VectorXd::Zero(m);
    a[j] = k * dtheta[j];
    Vector6d dW = e.s_t.cwiseProduct(J * (-K_pinv(a)));
    const JointSpec& spec = model.joint(problem.columns()[static_cast<size_t>(j)]);
    const bool base = spec.role == JointRole::kBase;
    if (base) {
      base_sum += a;
      any_base = true;
      base_k = std::max(base_k, k);
    }
    add(model.joint_names()[static_cast<size_t>(problem.columns()[static_cast<size_t>(j)])],
        base ? "base" : "joint", k, spec.type == JointType::kPrismatic ? "N/m" : "N·m/rad", dW);
  }
  if (any_base) {
    Vector6d dW = e.s_t.cwiseProduct(J * (-K_pinv(base_sum)));
    add("base (all base joints scaled together)", "base", base_k, "N/m", dW);
  }
  out.ok = true;
  out.message = out.entries.empty() ? "no stiffness to vary"
                                    : "analytic dW/dlog k, K^+ on eigenvalues > " +
                                          util::FormatNumber(threshold, 3);
  if (!any_base) {
    out.message +=
        "; the model has no base dofs (a rigid base): give --base-stiffness to see the base's "
        "effect";
  }
  return out;
}

}  // namespace isowrench
