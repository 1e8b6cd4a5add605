#pragma once
// Private: the dimensionless Jacobian every diagnostic rank decision uses, and small helpers.
// Translation rows are divided by a length scale L and prismatic columns multiplied by it, so
// every entry is rad/rad (or m/m): J_s = D J E with D = diag(1/L on translation rows, 1) and
// E = diag(L on prismatic columns, 1). Then null(J) = E null(J_s), null(J^T) = D null(J_s^T).

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench::diagnostics {

/// Rows of the restrained transducer dofs, in order.
std::vector<int> RestrainedRows(const Model& model);

/// L: `length_scale` if > 0, else the leg length (StaticsProblem::leg_length(),
/// Model::chain_length()). @throws Error if not finite.
double LengthScale(const Model& model, double length_scale);

/// J_s on the given rows: (rows.size() x J.cols()); `prismatic` flags columns (may be longer
/// than model.dof_count() for expanded Jacobians).
Eigen::MatrixXd ScaledRows(const Matrix6Xd& J, const std::vector<int>& rows,
                           const std::vector<bool>& prismatic, double L);

/// Full SVD that also accepts matrices with no rows or no columns (Eigen's JacobiSVD does not):
/// then the singular values are empty and U, V are identities of the right sizes.
struct FullSvd {
  Eigen::VectorXd singular_values;  ///< descending
  Eigen::MatrixXd U;                ///< rows x rows
  Eigen::MatrixXd V;                ///< cols x cols
};
FullSvd ComputeFullSvd(const Eigen::MatrixXd& A);

/// Column flags from the model.
std::vector<bool> PrismaticColumns(const Model& model);

/// Prismatic flags of the model's columns `columns` (e.g. StaticsProblem::columns()).
std::vector<bool> PrismaticColumns(const Model& model, const std::vector<int>& columns);

/// J's columns `columns`, in that order (6 x columns.size()).
Matrix6Xd SelectColumns(const Matrix6Xd& J, const std::vector<int>& columns);

/// |D v| for a wrench v with D = diag(1, 1, 1, 1/L, 1/L, 1/L) (forces in N, moments / L).
double ScaledWrenchNorm(const Vector6d& w, double L);

/// "fx +1.000 N, fy -0.532 N, mz +0.0123 N·m", entries with |entry| <= cutoff * largest skipped.
std::string DescribeWrench(const Vector6d& w, double cutoff);

/// Flip v so that its largest-magnitude entry is positive (reproducible signs).
template <typename V>
void CanonicalSign(V& v) {
  Eigen::Index i = 0;
  v.cwiseAbs().maxCoeff(&i);
  if (v[i] < 0) v = -v;
}

}  // namespace isowrench::diagnostics
