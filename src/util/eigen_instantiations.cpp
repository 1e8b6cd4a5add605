// The one translation unit that compiles Eigen's heavy decompositions of dynamic-size double
// matrices (declared extern in eigen_instantiations.hpp for every other source).

#include "util/eigen_instantiations.hpp"

namespace Eigen {
template class JacobiSVD<MatrixXd>;
template class SelfAdjointEigenSolver<MatrixXd>;
template SelfAdjointEigenSolver<MatrixXd>& SelfAdjointEigenSolver<MatrixXd>::compute<MatrixXd>(
    const EigenBase<MatrixXd>& matrix, int options);
template class LLT<MatrixXd>;
template LLT<MatrixXd>& LLT<MatrixXd>::compute<MatrixXd>(const EigenBase<MatrixXd>& matrix);
template class LDLT<MatrixXd>;
template LDLT<MatrixXd>& LDLT<MatrixXd>::compute<MatrixXd>(const EigenBase<MatrixXd>& matrix);
template class ColPivHouseholderQR<MatrixXd>;
}  // namespace Eigen
