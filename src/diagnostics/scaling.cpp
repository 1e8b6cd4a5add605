#include "diagnostics/scaling.hpp"

#include <Eigen/SVD>
#include <cmath>
#include <cstdio>

#include "isowrench/error.hpp"
#include "isowrench/statics.hpp"
#include "util/eigen_instantiations.hpp"
#include "util/text.hpp"

namespace isowrench::diagnostics {

std::vector<int> RestrainedRows(const Model& model) {
  std::vector<int> rows;
  for (int i = 0; i < 6; ++i) {
    if (!model.transducer().released[i]) rows.push_back(i);
  }
  return rows;
}

double LengthScale(const Model& model, double length_scale) {
  if (!std::isfinite(length_scale)) {
    throw Error("length scale " + util::FormatNumber(length_scale) + " m is not finite");
  }
  double L = length_scale > 0 ? length_scale : StaticsProblem(model).leg_length();
  if (!(L > 0))
    throw Error("model '" + model.name() + "' has zero chain length; give a length scale");
  return L;
}

Eigen::MatrixXd ScaledRows(const Matrix6Xd& J, const std::vector<int>& rows,
                           const std::vector<bool>& prismatic, double L) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(rows.size()), J.cols());
  for (size_t k = 0; k < rows.size(); ++k) {
    out.row(static_cast<Eigen::Index>(k)) = J.row(rows[k]) * (rows[k] < 3 ? 1.0 / L : 1.0);
  }
  for (Eigen::Index c = 0; c < J.cols(); ++c) {
    if (static_cast<size_t>(c) < prismatic.size() && prismatic[static_cast<size_t>(c)])
      out.col(c) *= L;
  }
  return out;
}

FullSvd ComputeFullSvd(const Eigen::MatrixXd& A) {
  FullSvd out;
  if (A.rows() == 0 || A.cols() == 0) {
    out.singular_values.resize(0);
    out.U = Eigen::MatrixXd::Identity(A.rows(), A.rows());
    out.V = Eigen::MatrixXd::Identity(A.cols(), A.cols());
    return out;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  out.singular_values = svd.singularValues();
  out.U = svd.matrixU();
  out.V = svd.matrixV();
  return out;
}

std::vector<bool> PrismaticColumns(const Model& model) {
  std::vector<bool> p(static_cast<size_t>(model.dof_count()));
  for (int i = 0; i < model.dof_count(); ++i)
    p[static_cast<size_t>(i)] = model.joint(i).type == JointType::kPrismatic;
  return p;
}

std::vector<bool> PrismaticColumns(const Model& model, const std::vector<int>& columns) {
  std::vector<bool> p;
  for (int c : columns) p.push_back(model.joint(c).type == JointType::kPrismatic);
  return p;
}

Matrix6Xd SelectColumns(const Matrix6Xd& J, const std::vector<int>& columns) {
  Matrix6Xd out(6, static_cast<Eigen::Index>(columns.size()));
  for (size_t k = 0; k < columns.size(); ++k)
    out.col(static_cast<Eigen::Index>(k)) = J.col(columns[k]);
  return out;
}

double ScaledWrenchNorm(const Vector6d& w, double L) {
  Vector6d s = w;
  s.tail<3>() /= L;
  return s.norm();
}

std::string DescribeWrench(const Vector6d& w, double cutoff) {
  static const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  double largest = w.cwiseAbs().maxCoeff();
  std::vector<std::string> items;
  for (int i = 0; i < 6; ++i) {
    if (std::abs(w[i]) <= cutoff * largest || w[i] == 0.0) continue;
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%s %+.4g %s", names[i], w[i], i < 3 ? "N" : "N·m");
    items.push_back(buffer);
  }
  return items.empty() ? "(zero)" : util::Join(items, ", ");
}

}  // namespace isowrench::diagnostics
