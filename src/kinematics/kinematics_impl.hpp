#pragma once
// Private: KDL solvers behind KinematicsWorkspace. Each workspace owns a copy of the chain
// because KDL::Joint caches its last pose in mutable members (not thread-safe to share).

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>

#include "isowrench/kinematics.hpp"

namespace isowrench {

struct KinematicsWorkspace::Impl {
  explicit Impl(const KDL::Chain& c)
      : chain(c), fk(chain), jac_solver(chain), q(chain.getNrOfJoints()), jac(chain.getNrOfJoints()) {}
  KDL::Chain chain;
  KDL::ChainFkSolverPos_recursive fk;
  KDL::ChainJntToJacSolver jac_solver;
  KDL::JntArray q;
  KDL::Jacobian jac;
};

}  // namespace isowrench
