// Constraint class, self-motion (null(J_r)) and internal wrench (null(J_r^T)) of a restrained
// limb, plus DiagnoseLimb which puts every diagnostic together.

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
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

using diagnostics::CanonicalSign;

// Two joint origins closer than this fraction of the leg length are one joint centre; a point
// closer than this to a screw axis lies on it. Joint origins that coincide by construction agree
// to rounding (~1e-16 L), so the margin is wide; distinct centres are millimetres apart.
constexpr double kSamePointFraction = 1e-9;

std::string CommonPrefix(const std::vector<std::string>& names) {
  if (names.empty()) return "";
  std::string prefix = names[0];
  for (const std::string& n : names) {
    size_t k = 0;
    while (k < prefix.size() && k < n.size() && prefix[k] == n[k]) ++k;
    prefix.resize(k);
  }
  // Cut back to a word boundary: "hip_r" from hip_rz, hip_ry becomes "hip".
  for (const std::string& n : names) {
    if (prefix.size() < n.size() && n[prefix.size()] != '_' && n[prefix.size()] != '-') {
      size_t cut = prefix.find_last_of("_-");
      prefix = cut == std::string::npos ? "" : prefix.substr(0, cut);
      break;
    }
  }
  while (!prefix.empty() && (prefix.back() == '_' || prefix.back() == '-')) prefix.pop_back();
  return prefix;
}

// Geometric reading of a joint motion: find the bone (the link after the last joint of a
// joint centre) that turns fastest and say about which line it turns.
std::string InterpretMotion(const Model& model, const Eigen::VectorXd& q,
                            const Eigen::VectorXd& dtheta, const std::vector<JointCentre>& centres,
                            double L) {
  Data ws(model);
  Matrix6Xd Jw = EndpointJacobianWorld(model, ws, q);
  Eigen::Vector3d p_E = EndpointPose(model, ws, q).translation();
  // Named points the screw axis may pass through.
  std::vector<std::pair<std::string, Eigen::Vector3d>> points;
  for (const JointCentre& c : centres) points.emplace_back(c.name, c.position);
  points.emplace_back("endpoint", p_E);

  double best = 0.0;
  std::string best_text;
  for (const JointCentre& c : centres) {
    int last = model.JointIndex(c.joints.back());
    Vector6d twist = Jw.leftCols(last + 1) * dtheta.head(last + 1);  // reference point E
    Eigen::Vector3d w = twist.tail<3>();
    Eigen::Vector3d v = twist.head<3>();
    const std::string& bone = model.joint(last).child_link;
    if (w.norm() > best) {
      best = w.norm();
      Eigen::Vector3d point = p_E + w.cross(v) / w.squaredNorm();  // a point on the screw axis
      Eigen::Vector3d u = w.normalized();
      std::vector<std::string> on_axis;
      for (const auto& [name, p] : points) {
        if ((p - point).cross(u).norm() <= kSamePointFraction * L * 1e3) on_axis.push_back(name);
      }
      double pitch = std::abs(u.dot(v)) / w.norm();
      std::string screw =
          pitch > kSamePointFraction * L * 1e3 ? " with translation along it (a screw)" : "";
      if (on_axis.size() >= 2) {
        best_text =
            bone + " axial rotation (about the " + on_axis[0] + "-" + on_axis[1] + " line)" + screw;
      } else if (on_axis.size() == 1) {
        best_text = bone + " rotation about an axis through the " + on_axis[0] + screw;
      } else {
        best_text = bone + " rotation about an axis through no joint centre" + screw;
      }
    }
  }
  if (best_text.empty()) {
    // No bone turns: a translation (e.g. base dofs).
    Vector6d twist = Jw * dtheta;
    if (twist.head<3>().norm() > 0) best_text = "translation of the chain without rotation";
  }
  return best_text;
}

}  // namespace

const char* ConstraintClassName(ConstraintClass c) {
  switch (c) {
    case ConstraintClass::kMatched: return "matched";
    case ConstraintClass::kOverConstrained: return "over-constrained";
    case ConstraintClass::kUnderConstrained: return "under-constrained";
    case ConstraintClass::kDeficient: return "over- and under-constrained";
  }
  return "?";
}

std::vector<JointCentre> FindJointCentres(const Model& model, const Eigen::VectorXd& q) {
  ValidatePosture(model, q);
  Data ws(model);
  const double L = model.chain_length() > 0 ? model.chain_length() : 1.0;
  Eigen::Vector3d p_E = EndpointPose(model, ws, q).translation();
  std::vector<JointCentre> centres;
  for (int i = 0; i < model.dof_count(); ++i) {
    const JointSpec& j = model.joint(i);
    if (j.type != JointType::kRevolute) continue;
    Eigen::Vector3d p = PointPosition(model, ws, q, j.parent_link, j.origin.translation());
    if ((p - p_E).norm() <= kSamePointFraction * L) continue;  // at the endpoint: not proximal
    if (!centres.empty() && (centres.back().position - p).norm() <= kSamePointFraction * L &&
        model.JointIndex(centres.back().joints.back()) == i - 1) {
      centres.back().joints.push_back(j.name);
    } else {
      centres.push_back({"", {j.name}, p});
    }
  }
  for (JointCentre& c : centres) {
    c.name = CommonPrefix(c.joints);
    if (c.name.empty()) c.name = c.joints.front();
  }
  return centres;
}

ConstraintAnalysis AnalyzeConstraints(const Model& model, const Eigen::VectorXd& q,
                                      const ConstraintOptions& options) {
  ValidatePosture(model, q);
  if (!std::isfinite(options.rank_tolerance) || options.rank_tolerance < 0) {
    throw Error("rank tolerance " + util::FormatNumber(options.rank_tolerance) +
                " must be finite and >= 0");
  }
  ConstraintAnalysis a;
  a.length_scale = diagnostics::LengthScale(model, options.length_scale);
  const double L = a.length_scale;
  Data ws(model);
  a.jacobian = EndpointJacobian(model, ws, q);
  // The columns of K: locked coordinates are rigid and are no dof of the restrained limb.
  const StaticsProblem problem(model);
  const std::vector<int>& columns = problem.columns();
  a.locked = problem.LockedNames();
  std::vector<int> rows = diagnostics::RestrainedRows(model);
  std::vector<bool> prismatic = diagnostics::PrismaticColumns(model, columns);
  const int n = static_cast<int>(rows.size());
  const int m = static_cast<int>(columns.size());
  a.joint_count = m;
  a.restrained_count = n;
  for (int r : rows) a.restrained.set(r);
  a.rank_tolerance = options.rank_tolerance;

  Eigen::MatrixXd Js =
      diagnostics::ScaledRows(diagnostics::SelectColumns(a.jacobian, columns), rows, prismatic, L);
  const diagnostics::FullSvd svd = diagnostics::ComputeFullSvd(Js);
  a.singular_values = svd.singular_values;
  const double sigma_max = a.singular_values.size() ? a.singular_values[0] : 0.0;
  a.rank_threshold = options.rank_tolerance * sigma_max;
  a.rank = 0;
  for (Eigen::Index i = 0; i < a.singular_values.size(); ++i) {
    if (a.singular_values[i] > a.rank_threshold && sigma_max > 0) ++a.rank;
  }
  const bool internal = a.rank < n, self = a.rank < m;
  a.constraint_class = internal && self ? ConstraintClass::kDeficient
                       : internal       ? ConstraintClass::kOverConstrained
                       : self           ? ConstraintClass::kUnderConstrained
                                        : ConstraintClass::kMatched;
  std::string counts = std::to_string(m) + " joint dofs";
  if (!a.locked.empty()) {
    counts += " (" + std::to_string(a.locked.size()) + " locked coordinate" +
              (a.locked.size() == 1 ? "" : "s") + " not counted: " + util::Join(a.locked, ", ") +
              ")";
  }
  counts += ", " + std::to_string(n) + " restrained dofs, rank " + std::to_string(a.rank);
  switch (a.constraint_class) {
    case ConstraintClass::kMatched:
      a.explanation = counts +
                      ": the restrained dofs match the limb, so W = J_r^-T tau does not depend on "
                      "transducer or base compliance (joint springs aside)";
      break;
    case ConstraintClass::kOverConstrained:
      a.explanation = counts + ": " + std::to_string(n - a.rank) +
                      " internal wrench direction(s) the joint torques do not determine: W along "
                      "them is set by the compliances, or is 0 where the muscle does not load them";
      break;
    case ConstraintClass::kUnderConstrained:
      a.explanation = counts + ": " + std::to_string(m - a.rank) +
                      " self-motion(s) the transducer does not hold; only joint stiffness can";
      break;
    case ConstraintClass::kDeficient:
      a.explanation = counts +
                      ": both self-motions and internal wrenches (a singular posture or a "
                      "redundant chain)";
      break;
  }

  // Spring-free columns (not locked, S_p = 0).
  {
    const std::vector<int>& free = problem.spring_free_columns();
    Eigen::MatrixXd Jf = diagnostics::ScaledRows(diagnostics::SelectColumns(a.jacobian, free), rows,
                                                 diagnostics::PrismaticColumns(model, free), L);
    a.free_joint_count = static_cast<int>(free.size());
    a.free_rank = 0;
    if (Jf.cols() > 0 && n > 0) {
      const Eigen::VectorXd sf = diagnostics::ComputeFullSvd(Jf).singular_values;
      for (Eigen::Index i = 0; i < sf.size(); ++i) {
        if (sf[i] > options.rank_tolerance * sf[0] && sf[0] > 0) ++a.free_rank;
      }
    }
    const bool fi = a.free_rank < n, fs = a.free_rank < a.free_joint_count;
    a.free_class = fi && fs ? ConstraintClass::kDeficient
                   : fi     ? ConstraintClass::kOverConstrained
                   : fs     ? ConstraintClass::kUnderConstrained
                            : ConstraintClass::kMatched;
    if (a.free_joint_count < m) {
      a.explanation +=
          "; on the " + std::to_string(a.free_joint_count) + " joints without a spring (rank " +
          std::to_string(a.free_rank) + ") it is " + ConstraintClassName(a.free_class) +
          (a.free_class == ConstraintClass::kMatched ? ", so W does not depend on the compliances"
           : a.free_class == ConstraintClass::kUnderConstrained
               ? ", so a self-motion no stiffness holds exists"
               : ", so W can depend on the compliances (each muscle's sensitivities say whether "
                 "it does)");
    }
  }

  std::vector<JointCentre> centres = FindJointCentres(model, q);
  const Eigen::MatrixXd& V = svd.V;
  for (int c = a.rank; c < m; ++c) {
    Eigen::VectorXd d = V.col(c);
    for (int i = 0; i < m; ++i) {
      if (prismatic[static_cast<size_t>(i)]) d[i] *= L;  // dtheta = E v
    }
    d /= d.cwiseAbs().maxCoeff();
    CanonicalSign(d);
    const Eigen::VectorXd full = problem.Expand(d);  // 0 on locked coordinates
    a.self_motion.push_back(
        {full, DescribeJointMotion(model, full), InterpretMotion(model, q, full, centres, L)});
  }
  const Eigen::MatrixXd& U = svd.U;
  for (int c = a.rank; c < n; ++c) {
    Eigen::VectorXd u = U.col(c);
    CanonicalSign(u);
    InternalWrench iw;
    for (int k = 0; k < n; ++k) {
      if (std::abs(u[k]) <= options.component_cutoff) continue;  // rounding of an exact zero
      const int row = rows[static_cast<size_t>(k)];
      iw.direction[row] = row < 3 ? u[k] / L : u[k];  // w = D u
      iw.components.push_back(row);
    }
    // Largest |force| = 1 N when forces dominate in the D metric (|f| >= |m| / L), otherwise
    // largest |moment| = 1 N·m: no component exceeds max(1, 1 / L). The components the
    // direction does not touch are exactly 0, so rounding cannot set the scale.
    const double largest_force = iw.direction.head<3>().cwiseAbs().maxCoeff();
    const double largest_moment = iw.direction.tail<3>().cwiseAbs().maxCoeff();
    const double norm = largest_force >= largest_moment / L ? largest_force : largest_moment;
    if (norm > 0) iw.direction /= norm;
    iw.description = diagnostics::DescribeWrench(iw.direction, 0.0);
    a.internal_wrench.push_back(iw);
  }
  return a;
}

Diagnosis DiagnoseLimb(const Model& model, const Eigen::VectorXd& q, const std::string& muscle,
                       const DiagnosisOptions& options) {
  if (!std::isfinite(options.sensitivity_tolerance) || options.sensitivity_tolerance < 0) {
    throw Error("sensitivity tolerance " + util::FormatNumber(options.sensitivity_tolerance) +
                " must be finite and >= 0");
  }
  Diagnosis d;
  d.constraints = AnalyzeConstraints(model, q, options.constraints);
  d.evaluation = EvaluateWrench(model, q, muscle, options.activation, options.statics);
  std::vector<JointCentre> centres = FindJointCentres(model, q);
  const StaticsResult& s = d.evaluation.statics;
  for (Eigen::Index c = 0; c < s.self_motion.cols(); ++c) {
    Eigen::VectorXd v = s.self_motion.col(c);
    v /= v.cwiseAbs().maxCoeff();
    d.stiffness_null.push_back({v, DescribeJointMotion(model, v),
                                InterpretMotion(model, q, v, centres, d.constraints.length_scale)});
  }
  // The decomposition against the classic answer needs a classic answer: with base dofs it
  // treats the base springs as free joints and means nothing (as `wrench` says).
  d.classic_meaningful = StaticsProblem(model).base_columns().empty();
  if (!d.constraints.internal_wrench.empty() && d.evaluation.statics.ok() && d.classic_meaningful) {
    const double L = d.constraints.length_scale;
    const Eigen::Index k = static_cast<Eigen::Index>(d.constraints.internal_wrench.size());
    Eigen::MatrixXd N(6, k);
    for (Eigen::Index i = 0; i < k; ++i) {
      N.col(i) = d.constraints.internal_wrench[static_cast<size_t>(i)].direction;
      N.col(i).tail<3>() /= L;  // least squares in the D metric
    }
    Vector6d diff = d.evaluation.statics.wrench - d.evaluation.classic.wrench;
    Vector6d diff_s = diff;
    diff_s.tail<3>() /= L;
    d.internal_coefficients = N.colPivHouseholderQr().solve(diff_s);
    const double w = diagnostics::ScaledWrenchNorm(d.evaluation.statics.wrench, L);
    d.internal_residual = w > 0 ? (diff_s - N * d.internal_coefficients).norm() / w : 0.0;
  }
  d.sensitivity = ComputeStiffnessSensitivity(model, d.evaluation, d.constraints.length_scale,
                                              options.statics.rank_tolerance);
  if (!d.sensitivity.ok) {
    d.compliance_verdict = "no unique W, so no dependence on the compliances to state";
  } else if (d.sensitivity.entries.empty()) {
    d.compliance_verdict = "no compliance to vary";
  } else {
    const StiffnessSensitivity* largest = &d.sensitivity.entries.front();
    for (const StiffnessSensitivity& e : d.sensitivity.entries) {
      if (e.relative > largest->relative) largest = &e;
    }
    const std::string tol = util::FormatNumber(options.sensitivity_tolerance, 3);
    d.compliance_dependent = largest->relative > options.sensitivity_tolerance;
    d.compliance_verdict =
        d.compliance_dependent
            ? "W depends on the compliances: " + largest->parameter + " moves it by " +
                  util::FormatNumber(100 * largest->relative, 3) +
                  "% per e-fold, the most (relative sensitivity > " + tol + ")"
            : "W does not depend on any compliance: the largest relative sensitivity is " +
                  util::FormatNumber(largest->relative, 3) + " (" + largest->parameter +
                  ", <= " + tol + ")";
  }
  if (options.large_deflection) {
    d.large_deflection_run = true;
    d.large_deflection = SolveLargeDeflection(model, q, muscle, options.activation,
                                              options.large_deflection_options);
  }
  return d;
}

}  // namespace isowrench
