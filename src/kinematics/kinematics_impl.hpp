#pragma once
// Private: the entry point of the public kinematics functions into the kernel (fast/fast.cpp).

#include "fast/fast_impl.hpp"
#include "isowrench/kinematics.hpp"

namespace isowrench {

/// Validate q and run the kernel with frames on `ws` (see ComputeKinematicsWithFrames); returns
/// the buffers holding the results. @throws Error for a bad posture, muscle index or
/// activation, or coincident path points of the muscle (naming the muscle and the points).
Data::Impl& RunKinematics(const Model& model, Data& ws, const Eigen::VectorXd& q, int muscle,
                          double activation, bool world_axes);

}  // namespace isowrench
