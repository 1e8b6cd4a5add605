// Compliant statics (paper Eq. 6-10) and the classic J^-T / pinv answers (Eq. 11, 15).

#include "isowrench/statics.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <sstream>

#include "util/eigen_instantiations.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

std::string N(double v) { return util::FormatNumber(v, 3); }

}  // namespace

const char* StatusName(StaticsStatus status) {
  switch (status) {
    case StaticsStatus::kOk: return "ok";
    case StaticsStatus::kSelfMotionHeld: return "self-motion (not excited)";
    case StaticsStatus::kSelfMotion: return "self-motion";
    case StaticsStatus::kInvalidInput: return "invalid input";
  }
  return "?";
}

StaticsResult SolveStatics(const Matrix6Xd& J, const Vector6d& s_t, const Eigen::VectorXd& s_p,
                           const Eigen::VectorXd& tau, const StaticsOptions& options,
                           const std::vector<bool>& revolute) {
  StaticsResult r;
  const Eigen::Index m = J.cols();
  r.dtheta = Eigen::VectorXd::Zero(m);
  r.self_motion.resize(m, 0);
  auto invalid = [&](const std::string& why) {
    r.status = StaticsStatus::kInvalidInput;
    r.message = why;
    return r;
  };
  if (m == 0) return invalid("the Jacobian has no columns (no movable joints)");
  if (s_p.size() != m || tau.size() != m) {
    return invalid("sizes differ: J has " + std::to_string(m) + " columns, S_p has " +
                   std::to_string(s_p.size()) + " entries, tau has " + std::to_string(tau.size()));
  }
  if (!revolute.empty() && static_cast<Eigen::Index>(revolute.size()) != m) {
    return invalid("revolute flags: " + std::to_string(revolute.size()) + " given for " +
                   std::to_string(m) + " joints");
  }
  if (!J.allFinite()) return invalid("the Jacobian has a non-finite entry");
  if (!tau.allFinite()) return invalid("tau has a non-finite entry");
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(s_t[i]) || s_t[i] < 0) {
      return invalid(std::string("S_t ") + DofName(i) + " = " + N(s_t[i]) +
                     " must be finite and >= 0");
    }
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    if (!std::isfinite(s_p[i]) || s_p[i] < 0) {
      return invalid("S_p entry " + std::to_string(i) + " = " + N(s_p[i]) +
                     " must be finite and >= 0");
    }
  }

  // K = J^T S_t J + S_p (symmetric positive semi-definite). Its eigen-decomposition is its SVD;
  // rank is decided against the explicit threshold rank_tolerance * lambda_max.
  Eigen::MatrixXd K = J.transpose() * s_t.asDiagonal() * J;
  K.diagonal() += s_p;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
  r.k_eigenvalues = eig.eigenvalues();
  const Eigen::MatrixXd& V = eig.eigenvectors();
  const double lambda_max = std::max(r.k_eigenvalues[m - 1], 0.0);
  r.rank_threshold = options.rank_tolerance * lambda_max;
  std::vector<Eigen::Index> null_columns;
  double lambda_min_regular = lambda_max;
  for (Eigen::Index i = 0; i < m; ++i) {
    double lambda = r.k_eigenvalues[i];
    if (lambda <= r.rank_threshold || lambda_max == 0.0) {
      null_columns.push_back(i);
    } else {
      r.dtheta += V.col(i) * (V.col(i).dot(tau) / lambda);
      lambda_min_regular = std::min(lambda_min_regular, lambda);
    }
  }
  r.k_rank = static_cast<int>(m - null_columns.size());
  r.k_condition = r.k_rank > 0 ? lambda_max / lambda_min_regular : 0.0;
  r.self_motion.resize(m, static_cast<Eigen::Index>(null_columns.size()));
  bool excited = false;
  const double tau_norm = tau.norm();
  for (size_t c = 0; c < null_columns.size(); ++c) {
    Eigen::VectorXd v = V.col(null_columns[c]);
    // Sign convention: largest-magnitude entry positive, so reports are reproducible.
    Eigen::Index largest;
    v.cwiseAbs().maxCoeff(&largest);
    if (v[largest] < 0) v = -v;
    r.self_motion.col(static_cast<Eigen::Index>(c)) = v;
    if (std::abs(v.dot(tau)) > options.excitation_tolerance * tau_norm) excited = true;
  }

  r.endpoint_displacement = J * r.dtheta;
  if (excited) {
    r.status = StaticsStatus::kSelfMotion;
    r.message = "K = J^T S_t J + S_p is singular (rank " + std::to_string(r.k_rank) + " of " +
                std::to_string(m) +
                ") and the muscle torque drives the self-motion: no stiffness "
                "holds it, so there is no equilibrium and no wrench";
    r.wrench.setZero();
  } else {
    r.wrench = s_t.cwiseProduct(r.endpoint_displacement);
    r.status = null_columns.empty() ? StaticsStatus::kOk : StaticsStatus::kSelfMotionHeld;
    r.message = null_columns.empty()
                    ? "K positive definite (condition " + N(r.k_condition) + ")"
                    : "K is singular (rank " + std::to_string(r.k_rank) + " of " +
                          std::to_string(m) +
                          ") but the muscle torque does not drive the self-motion: W is unique";
  }
  r.equilibrium_residual = (J.transpose() * r.wrench + s_p.cwiseProduct(r.dtheta) - tau).norm();

  // Small-motion rule (MODEL.md "Validity of the linear model").
  r.endpoint_translation = r.endpoint_displacement.head<3>().norm();
  r.endpoint_translation_limit =
      options.leg_length > 0 ? options.max_endpoint_fraction * options.leg_length : 0.0;
  r.max_joint_rotation_limit = options.max_joint_rotation;
  double max_prismatic = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    bool is_revolute = revolute.empty() || revolute[static_cast<size_t>(i)];
    if (is_revolute) {
      r.max_joint_rotation = std::max(r.max_joint_rotation, std::abs(r.dtheta[i]));
    } else {
      max_prismatic = std::max(max_prismatic, std::abs(r.dtheta[i]));
    }
  }
  std::vector<std::string> problems;
  if (options.leg_length > 0 && r.endpoint_translation > r.endpoint_translation_limit) {
    problems.push_back("endpoint moves " + N(r.endpoint_translation) + " m > " +
                       N(r.endpoint_translation_limit) + " m (" +
                       N(options.max_endpoint_fraction * 100) + "% of leg length)");
  }
  if (options.leg_length > 0 && max_prismatic > r.endpoint_translation_limit) {
    problems.push_back("a prismatic joint moves " + N(max_prismatic) + " m > " +
                       N(r.endpoint_translation_limit) + " m");
  }
  if (r.max_joint_rotation > options.max_joint_rotation) {
    problems.push_back("a joint turns " + N(r.max_joint_rotation) + " rad > " +
                       N(options.max_joint_rotation) + " rad");
  }
  r.small_motion_valid = problems.empty() && r.status != StaticsStatus::kSelfMotion;
  if (!problems.empty()) {
    r.validity_message =
        "small-motion assumption violated: " + util::Join(problems, "; ") +
        ". J and tau are not constant over this motion; the linear answer is not valid";
  }
  return r;
}

ClassicResult ClassicWrench(const Matrix6Xd& J, const DofMask& released, const Eigen::VectorXd& tau,
                            double rank_tolerance) {
  ClassicResult out;
  std::vector<int> rows;
  for (int i = 0; i < 6; ++i) {
    if (!released[i]) rows.push_back(i);
  }
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  const Eigen::Index m = J.cols();
  auto invalid = [&out](const std::string& why) {
    out.status = StaticsStatus::kInvalidInput;
    out.message = "classic answer not computed: " + why;
    return out;
  };
  if (n == 0) return invalid("every transducer dof is released (no restrained row)");
  if (m == 0) return invalid("the Jacobian has no columns");
  if (tau.size() != m) {
    return invalid("tau has " + std::to_string(tau.size()) + " entries for " + std::to_string(m) +
                   " columns");
  }
  if (!J.allFinite()) return invalid("the Jacobian has a non-finite entry");
  if (!tau.allFinite()) return invalid("tau has a non-finite entry");
  Eigen::MatrixXd Jr(n, m);
  for (Eigen::Index k = 0; k < n; ++k) Jr.row(k) = J.row(rows[k]);
  // Solve J_r^T W_r = tau: minimum-norm least squares via SVD of J_r^T (m x n).
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jr.transpose(), Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  double threshold = sigma.size() ? rank_tolerance * sigma[0] : 0.0;
  Eigen::VectorXd Wr = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    if (sigma[i] > threshold) {
      ++out.rank;
      Wr += svd.matrixV().col(i) * (svd.matrixU().col(i).dot(tau) / sigma[i]);
    }
  }
  out.square_inverse = (n == m && out.rank == n);
  out.residual = (Jr.transpose() * Wr - tau).norm();
  for (Eigen::Index k = 0; k < n; ++k) out.wrench[rows[k]] = Wr[k];
  const std::string what = out.square_inverse ? "J_r^-T tau" : "pinv(J_r^T) tau";
  const std::string rank =
      "rank " + std::to_string(out.rank) + " of " + std::to_string(std::min(n, m));
  if (out.residual > 1e-9 * tau.norm()) {
    out.status = StaticsStatus::kSelfMotion;
    out.message = what + " (" + rank + "): the " + std::to_string(n) +
                  " restrained rows cannot balance tau (|J_r^T W - tau| = " + N(out.residual) +
                  "); without compliance the limb moves; W is the least-squares answer";
  } else if (out.rank < std::min(n, m)) {
    out.status = StaticsStatus::kSelfMotionHeld;
    out.message =
        what + " (" + rank + "): J_r is rank deficient but tau is reachable; minimum-norm W";
  } else {
    out.status = StaticsStatus::kOk;
    out.message = what + " (" + rank + ")";
  }
  return out;
}

}  // namespace isowrench
