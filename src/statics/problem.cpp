// The statics problem of a model (StaticsProblem): which coordinates are columns of K (free or
// held by a spring) and which are locked, the effective stiffnesses and the leg length. The one
// definition EvaluateWrench, the diagnostics, the release comparison and the fit read.

#include "isowrench/error.hpp"
#include "isowrench/statics.hpp"
#include "util/text.hpp"

namespace isowrench {

const char* CoordinateUseName(CoordinateUse use) {
  switch (use) {
    case CoordinateUse::kFree: return "free";
    case CoordinateUse::kSpring: return "spring";
    case CoordinateUse::kLocked: return "locked";
  }
  return "?";
}

StaticsProblem::StaticsProblem(const Model& model)
    : StaticsProblem(model, model.model_stiffness()) {}

StaticsProblem::StaticsProblem(const Model& model, const StiffnessSet& stiffness)
    : model_(model), stiffness_(stiffness) {
  const int m = model.dof_count();
  if (stiffness.s_p.size() != m) {
    throw Error("S_p has " + std::to_string(stiffness.s_p.size()) + " entries; model '" +
                model.name() + "' has " + std::to_string(m) + " coordinates");
  }
  for (int i = 0; i < 6; ++i) {
    if (model.transducer().released[i]) stiffness_.s_t[i] = 0.0;
  }
  use_.resize(static_cast<size_t>(m));
  for (int c = 0; c < m; ++c) {
    CoordinateUse u = model.coordinate(c).locked ? CoordinateUse::kLocked
                      : stiffness.s_p[c] > 0     ? CoordinateUse::kSpring
                                                 : CoordinateUse::kFree;
    use_[static_cast<size_t>(c)] = u;
    if (u == CoordinateUse::kLocked) {
      locked_.push_back(c);
    } else {
      columns_.push_back(c);
      if (u == CoordinateUse::kFree) spring_free_.push_back(c);
      if (model.joint(c).role == JointRole::kBase) base_.push_back(c);
    }
  }
}

const char* StaticsProblem::RoleLabel(int column) const {
  return locked(column) ? "locked" : RoleName(model_.joint(column).role);
}

std::vector<std::string> StaticsProblem::LockedNames() const {
  std::vector<std::string> names;
  for (int c : locked_) names.push_back(model_.joint_names()[static_cast<size_t>(c)]);
  return names;
}

double StaticsProblem::leg_length() const { return model_.chain_length(); }

Matrix6Xd StaticsProblem::Reduce(const Matrix6Xd& J) const {
  Matrix6Xd out(6, static_cast<Eigen::Index>(columns_.size()));
  for (size_t i = 0; i < columns_.size(); ++i) {
    out.col(static_cast<Eigen::Index>(i)) = J.col(columns_[i]);
  }
  return out;
}

Eigen::VectorXd StaticsProblem::Reduce(const Eigen::VectorXd& v) const {
  Eigen::VectorXd out(static_cast<Eigen::Index>(columns_.size()));
  for (size_t i = 0; i < columns_.size(); ++i) out[static_cast<Eigen::Index>(i)] = v[columns_[i]];
  return out;
}

std::vector<bool> StaticsProblem::reduced_revolute() const {
  std::vector<bool> out;
  for (int c : columns_) out.push_back(model_.revolute(c));
  return out;
}

Eigen::VectorXd StaticsProblem::Expand(const Eigen::VectorXd& reduced) const {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(coordinate_count());
  if (reduced.size() != static_cast<Eigen::Index>(columns_.size())) return out;
  for (size_t i = 0; i < columns_.size(); ++i)
    out[columns_[i]] = reduced[static_cast<Eigen::Index>(i)];
  return out;
}

Eigen::MatrixXd StaticsProblem::ExpandRows(const Eigen::MatrixXd& reduced) const {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(coordinate_count(), reduced.cols());
  // .row() of an n x 0 matrix offsets a null pointer (UBSan): copy only a non-empty matrix.
  if (reduced.cols() == 0 || reduced.rows() != static_cast<Eigen::Index>(columns_.size())) {
    return out;
  }
  for (size_t i = 0; i < columns_.size(); ++i) {
    out.row(columns_[i]) = reduced.row(static_cast<Eigen::Index>(i));
  }
  return out;
}

StaticsResult StaticsProblem::Solve(const Matrix6Xd& J, const Eigen::VectorXd& tau,
                                    const StaticsOptions& options) const {
  StaticsOptions opts = options;
  if (opts.leg_length <= 0) opts.leg_length = leg_length();
  if (J.cols() != coordinate_count() || tau.size() != coordinate_count()) {
    // Wrong sizes: SolveStatics says so (it checks them against each other).
    return SolveStatics(J, stiffness_.s_t, stiffness_.s_p, tau, opts);
  }
  if (columns_.empty()) {
    StaticsResult r = SolveStatics(J, stiffness_.s_t, stiffness_.s_p, tau, opts);
    r.status = StaticsStatus::kInvalidInput;
    r.message = "every coordinate of model '" + model_.name() +
                "' is locked: K has no column, the limb cannot move (unlock one with --lock)";
    r.wrench.setZero();
    r.dtheta.setZero();
    r.self_motion.resize(coordinate_count(), 0);
    return r;
  }
  if (locked_.empty()) {
    return SolveStatics(J, stiffness_.s_t, stiffness_.s_p, tau, opts, reduced_revolute());
  }
  StaticsResult r =
      SolveStatics(Reduce(J), stiffness_.s_t, reduced_s_p(), Reduce(tau), opts, reduced_revolute());
  r.dtheta = Expand(r.dtheta);
  r.self_motion = ExpandRows(r.self_motion);
  return r;
}

ClassicResult StaticsProblem::Classic(const Matrix6Xd& J, const Eigen::VectorXd& tau) const {
  if (locked_.empty() || J.cols() != coordinate_count() || tau.size() != coordinate_count()) {
    return ClassicWrench(J, model_.transducer().released, tau);
  }
  return ClassicWrench(Reduce(J), model_.transducer().released, Reduce(tau));
}

}  // namespace isowrench
