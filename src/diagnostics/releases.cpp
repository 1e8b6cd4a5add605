// Comparing released-dof choices. A release about axis a through the endpoint is a
// zero-stiffness joint between endpoint and transducer (MODEL.md "Released dofs") with Jacobian
// column [0; a] (rotation) or [a; 0] (translation), in transducer axes.

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>

#include "diagnostics/scaling.hpp"
#include "isowrench/diagnostics.hpp"
#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

using diagnostics::ScaledWrenchNorm;

std::string N3(double v) { return util::FormatNumber(v, 3); }

// Components below 1e-12 are rounding of an exact zero (axes are unit vectors): print 0.
std::string AxisText(const Eigen::Vector3d& a) {
  auto c = [](double v) { return N3(std::abs(v) < 1e-12 ? 0.0 : v); };
  return "(" + c(a.x()) + ", " + c(a.y()) + ", " + c(a.z()) + ")";
}

// Everything about one muscle at one posture that a release assessment needs: J (transducer
// axes), tau, S_p and the column kinds on the columns of K (StaticsProblem::columns(): locked
// coordinates are rigid and are no column), with and without base translation dofs.
struct System {
  Matrix6Xd J;
  Eigen::VectorXd tau, s_p;
  std::vector<bool> prismatic;
  std::vector<int> base_columns;  // indices into the system's columns
  std::vector<int> coordinates;   // the model coordinate of each column (before any release)
};

System MakeSystem(const Matrix6Xd& J, const Eigen::VectorXd& tau, const Model& model) {
  const StaticsProblem problem(model);
  System s;
  s.J = problem.Reduce(J);
  s.tau = problem.Reduce(tau);
  s.s_p = problem.reduced_s_p();
  s.coordinates = problem.columns();
  s.prismatic = diagnostics::PrismaticColumns(model, s.coordinates);
  for (size_t i = 0; i < s.coordinates.size(); ++i) {
    const std::vector<int>& base = problem.base_columns();
    if (std::find(base.begin(), base.end(), s.coordinates[i]) != base.end())
      s.base_columns.push_back(static_cast<int>(i));
  }
  return s;
}

System MakeSystem(const WrenchEvaluation& e, const Model& model) {
  return MakeSystem(e.jacobian, e.tau, model);
}

System WithoutColumns(const System& s, const std::vector<int>& drop) {
  System out;
  std::vector<int> keep;
  for (int c = 0; c < s.J.cols(); ++c) {
    if (std::find(drop.begin(), drop.end(), c) == drop.end()) keep.push_back(c);
  }
  const Eigen::Index k = static_cast<Eigen::Index>(keep.size());
  out.J.resize(6, k);
  out.tau.resize(k);
  out.s_p.resize(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const int c = keep[static_cast<size_t>(i)];
    out.J.col(i) = s.J.col(c);
    out.tau[i] = s.tau[c];
    out.s_p[i] = s.s_p[c];
    out.prismatic.push_back(s.prismatic[static_cast<size_t>(c)]);
    if (static_cast<size_t>(c) < s.coordinates.size())
      out.coordinates.push_back(s.coordinates[static_cast<size_t>(c)]);
  }
  return out;
}

// The model's system, the rigid-base system and a system with base dofs (stiffness to be set).
struct Systems {
  System model, rigid, base;
  Eigen::Matrix3d R_W_T;
  WrenchEvaluation evaluation;
};

// The system with base dofs is built only when the range has a base stiffness > 0 (it is a
// second Model with three more joints).
Systems BuildSystems(const Model& model, const Eigen::VectorXd& q, const std::string& muscle,
                     double activation, const StaticsOptions& statics,
                     const StiffnessRange& range) {
  const bool need_base = std::any_of(range.base_stiffness.begin(), range.base_stiffness.end(),
                                     [](double k) { return k > 0; });
  Systems out;
  out.evaluation = EvaluateWrench(model, q, muscle, activation, statics);
  out.R_W_T = out.evaluation.R_W_T;
  out.model = MakeSystem(out.evaluation, model);
  if (!out.model.base_columns.empty()) {
    out.base = out.model;
    out.rigid = WithoutColumns(out.model, out.model.base_columns);
  } else {
    out.rigid = out.model;
    if (!need_base) return out;
    Model base_model(WithBaseStiffness(model.description(), 1.0));
    Eigen::VectorXd qb = Eigen::VectorXd::Zero(base_model.dof_count());
    for (int i = 0; i < model.dof_count(); ++i)
      qb[base_model.JointIndex(model.joint_names()[i])] = q[i];
    out.base = MakeSystem(EvaluateWrench(base_model, qb, muscle, activation, statics), base_model);
  }
  return out;
}

Vector6d ReleaseColumn(ReleaseKind kind, const Eigen::Vector3d& axis_t) {
  Vector6d c = Vector6d::Zero();
  if (kind == ReleaseKind::kRotation) c.tail<3>() = axis_t;
  if (kind == ReleaseKind::kTranslation) c.head<3>() = axis_t;
  return c;
}

System Expand(const System& s, const ReleaseCandidate& cand, const Eigen::Vector3d& axis_t) {
  if (cand.kind == ReleaseKind::kNone) return s;
  System out = s;
  const Eigen::Index m = s.J.cols();
  out.J.conservativeResize(6, m + 1);
  out.J.col(m) = ReleaseColumn(cand.kind, axis_t);
  out.tau.conservativeResize(m + 1);
  out.tau[m] = 0.0;
  out.s_p.conservativeResize(m + 1);
  out.s_p[m] = 0.0;
  out.prismatic.push_back(cand.kind == ReleaseKind::kTranslation);
  return out;
}

std::vector<bool> Revolute(const System& s) {
  std::vector<bool> r;
  for (bool p : s.prismatic) r.push_back(!p);
  return r;
}

struct Margin {
  int rank = 0;
  int columns = 0;
  double margin = 0.0;             // sigma_min / sigma_max, 0 when columns > rows
  Eigen::VectorXd null_direction;  // a unit null vector (columns), when rank < columns
};

// Columns without a spring: only these can carry a self-motion (K v = 0 needs J_r v = 0 and
// S_p v = 0), and only these fix W independently of the compliances.
std::vector<int> FreeColumns(const System& s) {
  std::vector<int> free;
  for (Eigen::Index c = 0; c < s.s_p.size(); ++c) {
    if (!(s.s_p[c] > 0)) free.push_back(static_cast<int>(c));
  }
  return free;
}

Margin ComputeMargin(const System& s, const std::vector<int>& rows, double L,
                     double rank_tolerance) {
  Margin out;
  const std::vector<int> free = FreeColumns(s);
  Matrix6Xd Jf(6, static_cast<Eigen::Index>(free.size()));
  std::vector<bool> prismatic;
  for (size_t k = 0; k < free.size(); ++k) {
    Jf.col(static_cast<Eigen::Index>(k)) = s.J.col(free[k]);
    prismatic.push_back(s.prismatic[static_cast<size_t>(free[k])]);
  }
  Eigen::MatrixXd Js = diagnostics::ScaledRows(Jf, rows, prismatic, L);
  out.columns = static_cast<int>(Js.cols());
  const diagnostics::FullSvd svd = diagnostics::ComputeFullSvd(Js);
  const Eigen::VectorXd& sv = svd.singular_values;
  const double smax = sv.size() ? sv[0] : 0.0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) {
    if (smax > 0 && sv[i] > rank_tolerance * smax) ++out.rank;
  }
  // No columns: nothing can move (margin 1 by convention); more columns than rows: margin 0.
  out.margin = Js.cols() == 0                         ? 1.0
               : (Js.cols() <= Js.rows() && smax > 0) ? sv[Js.cols() - 1] / smax
                                                      : 0.0;
  if (out.rank < out.columns) {
    Eigen::VectorXd v = svd.V.col(out.columns - 1);
    out.null_direction = Eigen::VectorXd::Zero(s.J.cols());
    for (size_t k = 0; k < free.size(); ++k) {
      out.null_direction[free[k]] = v[static_cast<Eigen::Index>(k)] * (prismatic[k] ? L : 1.0);
    }
  }
  return out;
}

Eigen::Vector3d ToTransducer(const Eigen::Matrix3d& R_W_T, const Eigen::Vector3d& a) {
  return R_W_T.transpose() * a;
}

const char* KindName(ReleaseKind k) {
  switch (k) {
    case ReleaseKind::kNone: return "none";
    case ReleaseKind::kRotation: return "rotation";
    case ReleaseKind::kTranslation: return "translation";
  }
  return "?";
}

ReleaseAssessment Assess(const Model& model, const Systems& sys, const ReleaseCandidate& cand,
                         const ReleaseOptions& options, double L) {
  ReleaseAssessment a;
  a.candidate = cand;
  a.axis_transducer = cand.kind == ReleaseKind::kNone ? Eigen::Vector3d::Zero()
                                                      : ToTransducer(sys.R_W_T, cand.axis_world);
  const std::vector<int> rows = diagnostics::RestrainedRows(model);
  const int n = static_cast<int>(rows.size());
  System expanded = Expand(sys.model, cand, a.axis_transducer);
  Margin mg = ComputeMargin(expanded, rows, L, options.rank_tolerance);
  a.rank = mg.rank;
  a.columns = mg.columns;
  a.margin = mg.margin;
  a.self_motion = mg.rank < mg.columns;
  a.near_self_motion = !a.self_motion && mg.margin <= options.margin_warning;
  a.internal_wrench = mg.rank < n;
  a.torques_recoverable = !a.self_motion;

  const StaticsProblem problem(model);
  const Vector6d s_t = problem.stiffness().s_t;  // released rows 0
  StaticsOptions so = options.statics;
  if (so.leg_length <= 0) so.leg_length = problem.leg_length();
  a.statics = SolveStatics(expanded.J, s_t, expanded.s_p, expanded.tau, so, Revolute(expanded));

  // Spread over the stiffness range.
  const StiffnessRange& range = options.range;
  bool first = true;
  const double w_norm = ScaledWrenchNorm(a.statics.wrench, L);
  System base_expanded = Expand(sys.base, cand, a.axis_transducer);
  System rigid_expanded = Expand(sys.rigid, cand, a.axis_transducer);
  for (double ratio : range.rotational_ratios) {
    Vector6d grid_t;
    grid_t << range.translational, range.translational, range.translational,
        ratio * range.translational, ratio * range.translational, ratio * range.translational;
    for (int i = 0; i < 6; ++i) {
      if (model.transducer().released[i]) grid_t[i] = 0.0;
    }
    for (double kb : range.base_stiffness) {
      System s = kb > 0 ? base_expanded : rigid_expanded;
      if (kb > 0) {
        for (int c : sys.base.base_columns) s.s_p[c] = kb;
      }
      StaticsResult r = SolveStatics(s.J, grid_t, s.s_p, s.tau, so, Revolute(s));
      if (!r.ok()) {
        ++a.range_failures;
        continue;
      }
      if (first) {
        a.wrench_min = a.wrench_max = r.wrench;
        first = false;
      } else {
        a.wrench_min = a.wrench_min.cwiseMin(r.wrench);
        a.wrench_max = a.wrench_max.cwiseMax(r.wrench);
      }
      if (a.statics.ok() && w_norm > 0) {
        a.spread = std::max(a.spread, ScaledWrenchNorm(r.wrench - a.statics.wrench, L) / w_norm);
      }
    }
  }

  // Verdict.
  double restrained_part = 0.0;  // |release column on the restrained rows|
  if (cand.kind != ReleaseKind::kNone) {
    const Vector6d col = ReleaseColumn(cand.kind, a.axis_transducer);
    for (int r : rows) restrained_part = std::max(restrained_part, std::abs(col[r]));
  }
  // A unit axis whose restrained components are all rounding moves only released dofs.
  constexpr double kAlreadyFree = 1e-12;
  if (cand.kind != ReleaseKind::kNone && restrained_part <= kAlreadyFree) {
    a.verdict =
        "already free: the model's released dofs cover this motion, so releasing it adds nothing "
        "(and "
        "the extra joint would be a self-motion)";
  } else if (a.self_motion) {
    std::string motion;
    if (mg.null_direction.size() == expanded.J.cols()) {
      // Back to the model's coordinates (0 on locked ones; the release column left out).
      Eigen::VectorXd joints = Eigen::VectorXd::Zero(model.dof_count());
      for (size_t i = 0; i < sys.model.coordinates.size(); ++i)
        joints[sys.model.coordinates[i]] = mg.null_direction[static_cast<Eigen::Index>(i)];
      if (joints.cwiseAbs().maxCoeff() > 0)
        motion = "; self-motion: " + DescribeJointMotion(model, joints);
    }
    a.verdict =
        "forbidden: the limb can move without loading the transducer (expanded Jacobian rank " +
        std::to_string(a.rank) + " < " + std::to_string(a.columns) + " columns)" + motion;
  } else if (a.near_self_motion) {
    a.verdict = "near self-motion: margin " + N3(a.margin) + " <= " + N3(options.margin_warning) +
                "; the wrench amplifies small stiffness and geometry errors";
  } else if (a.internal_wrench) {
    const std::string over = std::string(cand.kind == ReleaseKind::kNone ? "" : "still ") +
                             "over-constrained (" + std::to_string(n - a.rank) +
                             " internal wrench direction(s))";
    if (a.statics.ok() && a.range_failures == 0 && a.spread <= options.spread_tolerance) {
      // The internal wrench directions exist but this muscle does not load them.
      a.verdict = over + " but W does not depend on the compliances: it moves by " +
                  N3(100 * a.spread) +
                  "% over the stiffness range (<= " + N3(100 * options.spread_tolerance) + "%)";
    } else {
      a.verdict = over + ": W moves by up to " + N3(100 * a.spread) + "% over the stiffness range";
    }
  } else {
    a.verdict = "matched: W = J_e^-T [tau; 0] whatever the compliances (spread " +
                N3(100 * a.spread) + "% over the range), margin " + N3(a.margin);
  }
  return a;
}

ForbiddenAxes Forbidden(const Eigen::MatrixXd& Js, const Eigen::MatrixXd& B, double tol,
                        const char* what) {
  ForbiddenAxes f;
  const diagnostics::FullSvd svd = diagnostics::ComputeFullSvd(Js);
  const Eigen::VectorXd& sv = svd.singular_values;
  const double smax = sv.size() ? sv[0] : 0.0;
  int rank = 0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) {
    if (smax > 0 && sv[i] > tol * smax) ++rank;
  }
  if (rank < Js.cols()) {
    f.dimension = 3;
    f.basis = Eigen::Matrix3d::Identity();
    f.description = std::string("every ") + what + " axis: the limb already has a self-motion";
    return f;
  }
  const Eigen::MatrixXd U = svd.U.leftCols(rank);
  Eigen::MatrixXd M =
      B - U * (U.transpose() * B);  // the part of each release column outside range(J_s)
  const diagnostics::FullSvd svd_m = diagnostics::ComputeFullSvd(M);
  const Eigen::VectorXd& s = svd_m.singular_values;
  std::vector<int> null;
  for (int i = 0; i < 3; ++i) {
    if (i >= s.size() || s[i] <= tol) null.push_back(i);  // no restrained rows: every axis
  }
  f.dimension = static_cast<int>(null.size());
  f.basis.resize(3, f.dimension);
  for (int k = 0; k < f.dimension; ++k) f.basis.col(k) = svd_m.V.col(null[static_cast<size_t>(k)]);
  if (f.dimension == 0) {
    f.description =
        std::string("none: every ") + what + " axis keeps the expanded Jacobian full rank";
  } else if (f.dimension == 1) {
    Eigen::Vector3d a = f.basis.col(0);
    diagnostics::CanonicalSign(a);
    f.basis.col(0) = a;
    f.description = std::string("one ") + what + " axis: " + AxisText(a) + " (world)";
  } else if (f.dimension == 2) {
    Eigen::Vector3d normal = svd_m.V.col(0);
    diagnostics::CanonicalSign(normal);
    f.plane_normal = normal;
    f.description = std::string("every ") + what + " axis in the plane with normal " +
                    AxisText(normal) + " (world)";
  } else {
    f.description = std::string("every ") + what + " axis";
  }
  return f;
}

}  // namespace

std::string StiffnessRange::Describe() const {
  std::vector<std::string> ratios, bases;
  for (double r : rotational_ratios) ratios.push_back(util::FormatNumber(r, 3));
  for (double b : base_stiffness) bases.push_back(b > 0 ? util::FormatNumber(b, 3) : "rigid");
  return "transducer kx = ky = kz = " + util::FormatNumber(translational, 3) +
         " N/m, krot = ratio x ktrans with ratio in {" + util::Join(ratios, ", ") +
         "} m²/rad; base stiffness in {" + util::Join(bases, ", ") +
         "} N/m; joint springs as in the model";
}

ReleaseCandidate MakeReleaseCandidate(const std::string& name, ReleaseKind kind,
                                      const Eigen::Vector3d& axis) {
  if (!axis.allFinite()) {
    throw Error("release axis '" + name + "' " + AxisText(axis) + " has a non-finite component");
  }
  // Below this length the axis has no reliable direction (axes are given in any unit length).
  constexpr double kMinAxisLength = 1e-12;
  if (axis.norm() <= kMinAxisLength) {
    throw Error("release axis '" + name + "' " + AxisText(axis) +
                " has zero length; give a direction");
  }
  if (kind == ReleaseKind::kNone)
    throw Error("release axis '" + name + "' needs a kind (rotation or translation)");
  return {name, kind, axis.normalized(), "user"};
}

std::vector<ReleaseCandidate> DefaultReleaseCandidates(const Model& model,
                                                       const Eigen::VectorXd& q) {
  ValidatePosture(model, q);
  Data ws(model);
  const Eigen::Matrix3d R = TransducerRotation(model, ws, q);
  std::vector<ReleaseCandidate> out;
  const auto& released = model.transducer().released;
  for (int i = 3; i < 6; ++i) {
    if (!released[i])
      out.push_back({DofName(i), ReleaseKind::kRotation, R.col(i - 3), "transducer axis"});
  }
  for (int i = 0; i < 3; ++i) {
    if (!released[i])
      out.push_back({DofName(i), ReleaseKind::kTranslation, R.col(i), "transducer axis"});
  }
  const Eigen::Vector3d p_E = EndpointPose(model, ws, q).translation();
  for (const JointCentre& c : FindJointCentres(model, q)) {
    out.push_back({"endpoint-" + c.name + " line", ReleaseKind::kRotation,
                   (c.position - p_E).normalized(), "joint centre"});
  }
  return out;
}

ReleaseAssessment AssessRelease(const Model& model, const Eigen::VectorXd& q,
                                const std::string& muscle, const ReleaseCandidate& candidate,
                                const ReleaseOptions& options) {
  const double L = diagnostics::LengthScale(model, options.length_scale);
  Systems sys = BuildSystems(model, q, muscle, options.activation, options.statics, options.range);
  return Assess(model, sys, candidate, options, L);
}

std::pair<ForbiddenAxes, ForbiddenAxes> FindForbiddenAxes(const Model& model,
                                                          const Eigen::VectorXd& q,
                                                          const ReleaseOptions& options) {
  ValidatePosture(model, q);
  const double L = diagnostics::LengthScale(model, options.length_scale);
  Data ws(model);
  const Matrix6Xd J = EndpointJacobian(model, ws, q);
  const Eigen::Matrix3d R = TransducerRotation(model, ws, q);
  const std::vector<int> rows = diagnostics::RestrainedRows(model);
  // Only the spring-free columns of K can carry a self-motion (locked ones are no column).
  const std::vector<int> free = StaticsProblem(model).spring_free_columns();
  const std::vector<bool> prismatic = diagnostics::PrismaticColumns(model, free);
  const Matrix6Xd Jf = diagnostics::SelectColumns(J, free);
  Eigen::MatrixXd Js = diagnostics::ScaledRows(Jf, rows, prismatic, L);
  // Release columns in scaled coordinates: rotation [0; R^T a], translation [R^T a; 0] (the
  // translation column is scaled by L like a prismatic joint, cancelling the row scaling).
  Eigen::MatrixXd B_rot = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()), 3);
  Eigen::MatrixXd B_trans = B_rot;
  for (size_t k = 0; k < rows.size(); ++k) {
    const int row = rows[k];
    if (row >= 3) B_rot.row(static_cast<Eigen::Index>(k)) = R.transpose().row(row - 3);
    if (row < 3) B_trans.row(static_cast<Eigen::Index>(k)) = R.transpose().row(row);
  }
  return {Forbidden(Js, B_rot, options.rank_tolerance, "rotation"),
          Forbidden(Js, B_trans, options.rank_tolerance, "translation")};
}

ReleaseComparison CompareReleases(const Model& model, const Eigen::VectorXd& q,
                                  const std::string& muscle,
                                  std::vector<ReleaseCandidate> candidates,
                                  const ReleaseOptions& options) {
  ValidatePosture(model, q);
  if (candidates.empty()) candidates = DefaultReleaseCandidates(model, q);
  ReleaseComparison out;
  out.muscle = muscle;
  out.length_scale = diagnostics::LengthScale(model, options.length_scale);
  out.range_description = options.range.Describe();
  Systems sys = BuildSystems(model, q, muscle, options.activation, options.statics, options.range);
  out.baseline =
      Assess(model, sys, {"none", ReleaseKind::kNone, Eigen::Vector3d::Zero(), "baseline"}, options,
             out.length_scale);
  for (const ReleaseCandidate& c : candidates)
    out.candidates.push_back(Assess(model, sys, c, options, out.length_scale));
  auto forbidden = FindForbiddenAxes(model, q, options);
  out.forbidden_rotations = forbidden.first;
  out.forbidden_translations = forbidden.second;

  // Rank: self-motion excluded; then safe before near self-motion, no internal wrench first,
  // compliance-independent (spread below tolerance) first, smaller spread, larger margin.
  std::vector<int> order;
  for (size_t i = 0; i < out.candidates.size(); ++i) {
    if (!out.candidates[i].self_motion) order.push_back(static_cast<int>(i));
  }
  auto key = [&](int i) {
    const ReleaseAssessment& a = out.candidates[static_cast<size_t>(i)];
    const bool independent = a.spread <= options.spread_tolerance;
    return std::make_tuple(a.near_self_motion, a.internal_wrench, !independent,
                           independent ? 0.0 : a.spread, -a.margin);
  };
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return key(x) < key(y); });
  for (size_t r = 0; r < order.size(); ++r)
    out.candidates[static_cast<size_t>(order[r])].rank_order = static_cast<int>(r + 1);

  const ReleaseAssessment& base = out.baseline;
  if (base.statics.ok() && !base.self_motion && !base.near_self_motion &&
      base.range_failures == 0 && base.spread <= options.spread_tolerance) {
    // W already does not depend on the compliances: a release can only remove a restraint.
    out.recommended = -1;
    out.release_needed = false;
    out.recommendation =
        "no release needed: W already does not depend on the compliances (it moves by " +
        N3(100 * base.spread) +
        "% over the stiffness range, <= " + N3(100 * options.spread_tolerance) +
        "%); keep the current restraint";
  } else if (order.empty() || out.candidates[static_cast<size_t>(order[0])].near_self_motion) {
    out.recommended = -1;
    out.recommendation =
        "no candidate is safe: every one allows (or nearly allows) a self-motion; " +
        std::string(out.baseline.internal_wrench
                        ? "keep all dofs restrained and model the compliances"
                        : "keep the current restraint");
  } else {
    out.recommended = order[0];
    const ReleaseAssessment& best = out.candidates[static_cast<size_t>(order[0])];
    out.recommendation = "release the " + std::string(KindName(best.candidate.kind)) + " " +
                         (best.candidate.kind == ReleaseKind::kRotation ? "about " : "along ") +
                         best.candidate.name + " (axis " + AxisText(best.candidate.axis_world) +
                         " world): " + best.verdict + ".";
    if (out.baseline.internal_wrench) {
      out.recommendation += " Without a release the wrench moves by up to " +
                            N3(100 * out.baseline.spread) + "% over the same stiffness range.";
    }
    if (order.size() > 1) {
      const ReleaseAssessment& next = out.candidates[static_cast<size_t>(order[1])];
      out.recommendation += " Next best: " + next.candidate.name + " (" +
                            KindName(next.candidate.kind) + ", margin " + N3(next.margin) + ").";
    }
    if (best.candidate.kind != ReleaseKind::kRotation) {
      // A bearing (a released rotation) is the usual hardware: name the best one too.
      for (int i : order) {
        const ReleaseAssessment& a = out.candidates[static_cast<size_t>(i)];
        if (a.candidate.kind == ReleaseKind::kRotation && !a.near_self_motion) {
          out.recommendation += " Best rotation release: " + a.candidate.name + " (rank " +
                                std::to_string(a.rank_order) + ", margin " + N3(a.margin) + ").";
          break;
        }
      }
    }
  }
  return out;
}

AxisSweep SweepReleaseAxes(const Model& model, const Eigen::VectorXd& q, int count,
                           std::uint64_t seed, const ReleaseOptions& options) {
  if (count < 1) throw Error("--sweep needs at least 1 sample; got " + std::to_string(count));
  ValidatePosture(model, q);
  const double L = diagnostics::LengthScale(model, options.length_scale);
  Data ws(model);
  const System s =
      MakeSystem(EndpointJacobian(model, ws, q), Eigen::VectorXd::Zero(model.dof_count()), model);
  const Eigen::Matrix3d R = TransducerRotation(model, ws, q);
  const std::vector<int> rows = diagnostics::RestrainedRows(model);
  AxisSweep out;
  out.samples = count;
  out.seed = seed;
  out.smallest_margin = INFINITY;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d a;
    do {
      a = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    } while (a.norm() < 1e-6);
    a.normalize();
    ReleaseCandidate c{"sample", ReleaseKind::kRotation, a, "sweep"};
    const Eigen::Vector3d a_t = R.transpose() * a;
    double restrained_part = 0.0;
    for (int r : rows) {
      if (r >= 3) restrained_part = std::max(restrained_part, std::abs(a_t[r - 3]));
    }
    Margin mg = ComputeMargin(Expand(s, c, a_t), rows, L, options.rank_tolerance);
    if (restrained_part <= 1e-12) {  // same rule as AssessRelease's "already free"
      ++out.already_free;
    } else if (mg.rank < mg.columns) {
      ++out.self_motion;
    } else if (mg.margin <= options.margin_warning) {
      ++out.near;
    } else {
      ++out.safe;
    }
    if (restrained_part > 1e-12 && mg.margin < out.smallest_margin) {
      out.smallest_margin = mg.margin;
      out.worst_axis = a;
    }
  }
  if (!std::isfinite(out.smallest_margin)) out.smallest_margin = 0.0;  // every axis already free
  return out;
}

}  // namespace isowrench
