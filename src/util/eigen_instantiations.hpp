#pragma once
// Private: Eigen's heavy decompositions of dynamic-size double matrices are compiled once, in
// src/util/eigen_instantiations.cpp (each costs seconds of compile time per translation unit
// that instantiates it). A source that uses one of them includes this header; the extern
// declarations below then stop the compiler from instantiating them again there.
// Only these exact types are covered: SelfAdjointEigenSolver<MatrixXd> constructed from (or
// computing) a MatrixXd, JacobiSVD<MatrixXd>, LLT/LDLT/ColPivHouseholderQR of a MatrixXd.

#include <Eigen/Dense>

namespace Eigen {
extern template class JacobiSVD<MatrixXd>;
extern template class SelfAdjointEigenSolver<MatrixXd>;
extern template SelfAdjointEigenSolver<MatrixXd>&
SelfAdjointEigenSolver<MatrixXd>::compute<MatrixXd>(const EigenBase<MatrixXd>& matrix, int options);
extern template class LLT<MatrixXd>;
extern template LLT<MatrixXd>& LLT<MatrixXd>::compute<MatrixXd>(const EigenBase<MatrixXd>& matrix);
extern template class LDLT<MatrixXd>;
extern template LDLT<MatrixXd>& LDLT<MatrixXd>::compute<MatrixXd>(
    const EigenBase<MatrixXd>& matrix);
extern template class ColPivHouseholderQR<MatrixXd>;
}  // namespace Eigen
