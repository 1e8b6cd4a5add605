#pragma once
/// @file
/// Shared helpers for the core tests: paths of the shipped URDFs and fixtures, random postures
/// from a locally seeded generator, and small linear-algebra utilities used as independent
/// references (never the library's own code).

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"
#include "util/eigen_instantiations.hpp"

namespace isowrench_test {

constexpr double kPi = 3.14159265358979323846;
constexpr double kEps = std::numeric_limits<double>::epsilon();

inline double Deg(double degrees) { return degrees * kPi / 180.0; }

inline std::string UrdfPath(const std::string& file) {
  return std::string(ISOWRENCH_TEST_URDF_DIR) + "/" + file;
}
inline std::string DataPath(const std::string& file) {
  return std::string(ISOWRENCH_TEST_DATA_DIR) + "/" + file;
}

/// Every URDF shipped in urdf/.
inline const std::vector<std::string>& ShippedUrdfs() {
  static const std::vector<std::string> kFiles = {
      "rat_hindlimb_5dof.urdf", "rat_hindlimb_6dof.urdf", "rat_hindlimb_5dof_base.urdf",
      "planar_2r.urdf", "planar_4r.urdf"};
  return kFiles;
}

inline isowrench::Model LoadModel(const std::string& file) {
  return isowrench::Model::FromUrdfFile(UrdfPath(file));
}
inline isowrench::LimbDescription LoadDescription(const std::string& file) {
  return isowrench::ReadUrdfFile(UrdfPath(file));
}

/// A random posture: revolute joints uniform in [-pi, pi] rad, prismatic joints uniform in
/// [-5, 5] mm (the base dofs model millimetre-scale fixation slack).
inline Eigen::VectorXd RandomPosture(const isowrench::Model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  std::uniform_real_distribution<double> slide(-0.005, 0.005);
  Eigen::VectorXd q(model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) {
    q[i] = model.joint(i).type == isowrench::JointType::kPrismatic ? slide(rng) : angle(rng);
  }
  return q;
}

/// vee() of the skew-symmetric part of a 3x3 matrix: S = [w]x  ->  w.
inline Eigen::Vector3d Vee(const Eigen::Matrix3d& s) {
  const Eigen::Matrix3d a = 0.5 * (s - s.transpose());
  return Eigen::Vector3d(a(2, 1), a(0, 2), a(1, 0));
}

/// K = J^T diag(s_t) J + diag(s_p), formed directly (the reference for conditioning).
inline Eigen::MatrixXd StiffnessAtJoints(const isowrench::Matrix6Xd& J,
                                         const isowrench::Vector6d& s_t,
                                         const Eigen::VectorXd& s_p) {
  Eigen::MatrixXd K = J.transpose() * s_t.asDiagonal() * J;
  K.diagonal() += s_p;
  return K;
}

/// Condition number lambda_max / lambda_min of a symmetric positive definite matrix.
inline double ConditionNumber(const Eigen::MatrixXd& K) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(K);
  const Eigen::VectorXd l = eig.eigenvalues();
  return l.maxCoeff() / std::max(l.minCoeff(), std::numeric_limits<double>::min());
}

/// Relative tolerance for results of one solve with K: a backward-stable factorization (LDLT)
/// gives a forward relative error below c * m * cond(K) * eps; c * m <= 1000 covers m <= 8 joints
/// with a wide margin. Never below 1e-12 (a few hundred eps: sums of ~10 products).
inline double SolveTolerance(const Eigen::MatrixXd& K) {
  return std::max(1e-12, 1e3 * ConditionNumber(K) * kEps);
}

}  // namespace isowrench_test
