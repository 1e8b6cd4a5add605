#pragma once
// Private: KinematicsWorkspace holds the buffers of the one kinematics kernel (fast/fast.cpp).

#include "fast/fast_impl.hpp"
#include "isowrench/kinematics.hpp"

namespace isowrench {

struct KinematicsWorkspace::Impl {
  explicit Impl(int dofs) : buffers(dofs) {}
  FastWorkspace::Impl buffers;
};

/// Validate q and run the kernel with frames on `ws` (see ComputeKinematicsWithFrames); returns
/// the buffers holding the results. @throws Error for a bad posture, muscle index or
/// activation, or coincident path points of the muscle (naming the muscle and the points).
FastWorkspace::Impl& RunKinematics(const Model& model, KinematicsWorkspace& ws,
                                   const Eigen::VectorXd& q, int muscle, double activation,
                                   bool world_axes);

}  // namespace isowrench
