// The reference translation unit of scripts/build_cost.sh: one function that runs Eigen's
// JacobiSVD and SelfAdjointEigenSolver on a MatrixXd. The build cost of isowrench is reported
// as a multiple of the CPU time it takes to compile this file at -O2, so that numbers measured
// on machines of different speed can be compared.
#include <Eigen/Dense>

double BuildCostReference(const Eigen::MatrixXd& a) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(a.transpose() * a);
  return svd.singularValues().sum() + eigen.eigenvalues().sum();
}
