#pragma once
// Shared by the statics tests (statics_*_test.cpp): names, the transducer stiffnesses every
// identity is checked with, and the (J, tau, S_p) of a model at a posture.

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/statics.hpp"

namespace isowrench_test {

using isowrench::Data;
using isowrench::EvaluateWrench;
using isowrench::LimbDescription;
using isowrench::Matrix6Xd;
using isowrench::Model;
using isowrench::SolveStatics;
using isowrench::StaticsResult;
using isowrench::StaticsStatus;
using isowrench::Vector6d;

inline Vector6d Diag6(double kx, double ky, double kz, double krx, double kry, double krz) {
  Vector6d s;
  s << kx, ky, kz, krx, kry, krz;
  return s;
}

// Transducer stiffnesses used across the identities: balanced, the two presets, a stiff-force /
// soft-moment attachment (paper Fig. 2D) and an anisotropic one with every entry different.
inline std::vector<Vector6d> SomeTransducerStiffnesses() {
  return {Vector6d::Constant(1e7), isowrench::TransducerPreset("ati-mini40"),
          isowrench::TransducerPreset("jr3"), Diag6(1e7, 1e7, 1e7, 1e3, 1e3, 1e3),
          Diag6(3e6, 2e7, 5e5, 40.0, 900.0, 7.0)};
}

struct Problem {
  Matrix6Xd J;
  Eigen::VectorXd tau;
  Eigen::VectorXd s_p;
};

inline Problem ProblemAt(const Model& model, const Eigen::VectorXd& q, const std::string& muscle) {
  Data ws(model);
  Problem p;
  p.J = isowrench::EndpointJacobian(model, ws, q);
  p.tau = isowrench::ComputeMuscleTorque(model, ws, q, model.MuscleIndex(muscle)).tau;
  p.s_p = model.joint_stiffness();
  return p;
}

inline Vector6d EffectiveSt(const Model& model) {
  Vector6d s = model.transducer().stiffness;
  for (int d = 0; d < 6; ++d) {
    if (model.transducer().released[d]) s[d] = 0.0;
  }
  return s;
}

}  // namespace isowrench_test
