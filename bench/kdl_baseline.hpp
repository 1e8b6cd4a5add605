#pragma once
// The straightforward KDL implementation of kernel K, kept as the benchmark's baseline: what a
// lab would write with KDL and Eigen without the fast path. Forward kinematics of every muscle
// path point (ChainFkSolverPos_recursive), the endpoint Jacobian (ChainJntToJacSolver), point
// Jacobians by ChainJntToJacSolver + Jacobian::changeRefPoint, then K = J^T S_t J + S_p and a
// dynamic-size Eigen LDLT. No validation, no statuses: the happy path only.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <vector>

#include "isowrench/model.hpp"

namespace isowrench_bench {

class KdlBaseline {
 public:
  KdlBaseline(const isowrench::Model& model, int muscle);
  /// W = S_t J (J^T S_t J + S_p)^-1 tau in world axes (the shipped rat URDFs have
  /// transducer axes = world axes).
  isowrench::Vector6d Evaluate(const Eigen::VectorXd& q, const isowrench::Vector6d& s_t,
                               const Eigen::VectorXd& s_p);

 private:
  KDL::Chain chain_;
  KDL::ChainFkSolverPos_recursive fk_;
  KDL::ChainJntToJacSolver jac_solver_;
  KDL::JntArray q_;
  KDL::Jacobian jac_;
  std::vector<int> point_segments_;
  std::vector<KDL::Vector> point_offsets_;
  double force_ = 0.0;
  int segments_ = 0;
};

}  // namespace isowrench_bench
