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

/// Leg length (m) of a constructed model, the value Model::chain_length() returns: the length of
/// the polyline through the joint centres, in column order, to the endpoint, at the nominal
/// posture (docs/model.md "Leg length"). A coordinate that turns a revolute joint has its centre
/// on its instantaneous screw axis, at the point nearest the first revolute joint it drives
/// (the joint's frame when no translation is coupled to it); coordinates that only translate have
/// none. Fixed offsets before the first joint centre (a clamp) do not count. A chain without
/// rotation: from the first movable joint's origin to the endpoint. Model's constructor calls it.
double ComputeLegLength(const Model& model);

}  // namespace isowrench
