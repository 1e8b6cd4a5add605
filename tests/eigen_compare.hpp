#pragma once
/// @file
/// Matrix comparison for GoogleTest (in the spirit of drake's CompareMatrices and manif's
/// gtest_eigen_utils): on failure the message prints both matrices, their difference and the
/// worst entry, so a failing test explains itself.
///
///   EXPECT_TRUE(MatricesNear(J, J_fd, /*abs_tol=*/1e-8));
///   EXPECT_TRUE(MatricesNear(W, W_ref, 0.0, /*rel_tol=*/1e-9));
///
/// Entry (i, j) passes when |a_ij - b_ij| <= abs_tol + rel_tol * max(|a|_max, |b|_max), i.e. the
/// relative part is taken against the largest entry of either matrix (a scale for the whole
/// matrix, not per entry: small entries of a wrench carry the rounding error of the large ones).
/// Sizes must match, and a NaN anywhere fails.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <sstream>
#include <string>

namespace isowrench_test {

template <typename DerivedA, typename DerivedB>
::testing::AssertionResult MatricesNear(const Eigen::MatrixBase<DerivedA>& a,
                                        const Eigen::MatrixBase<DerivedB>& b, double abs_tol,
                                        double rel_tol = 0.0) {
  const Eigen::MatrixXd A = a.template cast<double>();
  const Eigen::MatrixXd B = b.template cast<double>();
  const Eigen::IOFormat fmt(Eigen::FullPrecision, 0, ", ", "\n", "  [", "]");
  auto describe = [&](::testing::AssertionResult result) {
    std::ostringstream os;
    os.precision(17);
    os << "\nfirst (" << A.rows() << "x" << A.cols() << "):\n"
       << A.format(fmt) << "\nsecond (" << B.rows() << "x" << B.cols() << "):\n"
       << B.format(fmt);
    if (A.rows() == B.rows() && A.cols() == B.cols()) {
      os << "\nfirst - second:\n" << (A - B).format(fmt);
    }
    os << "\nabs_tol = " << abs_tol << ", rel_tol = " << rel_tol;
    return result << os.str();
  };
  if (A.rows() != B.rows() || A.cols() != B.cols()) {
    return describe(::testing::AssertionFailure() << "size mismatch");
  }
  if (A.hasNaN() || B.hasNaN()) {
    return describe(::testing::AssertionFailure() << "NaN in a matrix");
  }
  if (A.size() == 0) return ::testing::AssertionSuccess();
  const double scale = std::max(A.cwiseAbs().maxCoeff(), B.cwiseAbs().maxCoeff());
  const double tol = abs_tol + rel_tol * scale;
  Eigen::Index wi = 0, wj = 0;
  const double worst = (A - B).cwiseAbs().maxCoeff(&wi, &wj);
  if (!(worst <= tol)) {
    return describe(::testing::AssertionFailure() << "largest difference " << worst << " at (" << wi
                                                  << ", " << wj << ") exceeds tolerance " << tol);
  }
  return ::testing::AssertionSuccess();
}

/// True when no entry is NaN or infinite; the message prints the matrix otherwise.
template <typename Derived>
::testing::AssertionResult AllFinite(const Eigen::MatrixBase<Derived>& m) {
  if (m.allFinite()) return ::testing::AssertionSuccess();
  std::ostringstream os;
  os << "non-finite entry in\n" << m;
  return ::testing::AssertionFailure() << os.str();
}

}  // namespace isowrench_test
