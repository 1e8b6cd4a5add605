// A model's wrapping muscles at one posture for the reports (include/isowrench/wrap_report.hpp):
// the opensim-versus-exact comparison, from the engine's path (MuscleWrappedPath,
// ComputeMuscleTorque) in each mode; no walk of the muscle's points of its own.

#include "isowrench/wrap_report.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

// X_W_link(q) from three point positions (the link's frame may be offset from its chain frame,
// which PointPosition accounts for).
Eigen::Isometry3d WrapReportLinkPose(const Model& model, Data& data, const Eigen::VectorXd& q,
                                     const std::string& link) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d origin = PointPosition(model, data, q, link, Eigen::Vector3d::Zero());
  X.translation() = origin;
  for (int k = 0; k < 3; ++k) {
    X.linear().col(k) = PointPosition(model, data, q, link, Eigen::Vector3d::Unit(k)) - origin;
  }
  return X;
}

// The engine's path of one muscle in one mode: MuscleWrappedPath and the moment arms -dL/dq of
// ComputeMuscleTorque (the generalized force of a unit tension: in opensim mode OpenSim's
// MomentArmSolver's, in exact mode -dL/dq exactly; include/isowrench/wrap.hpp).
struct WrapReportEvaluation {
  WrappedPath path;
  Eigen::VectorXd moment_arm;
};

WrapReportEvaluation WrapReportEvaluate(const Model& model, Data& data, const Eigen::VectorXd& q,
                                        int muscle) {
  WrapReportEvaluation out;
  out.path = MuscleWrappedPath(model, data, q, muscle);
  out.moment_arm = -ComputeMuscleTorque(model, data, q, muscle).dL_dq.transpose();
  return out;
}

}  // namespace

Eigen::Isometry3d WrapObjectPose(const Model& model, Data& data, const Eigen::VectorXd& q,
                                 const WrapObjectSpec& object) {
  return WrapReportLinkPose(model, data, q, object.link) * object.Pose();
}

Model ModelInWrapMode(const Model& model, WrapMode mode) {
  LimbDescription d = model.description();
  d.wrap_mode = mode;
  return Model(d);
}

namespace {

WrapMode OtherWrapMode(const Model& model) {
  return model.description().wrap_mode == WrapMode::kOpenSim ? WrapMode::kExact
                                                             : WrapMode::kOpenSim;
}

// CompareWrapModes with the model in the other mode built by the caller (once per sweep).
WrapModeDifference CompareWrapModesWith(const Model& model, Data& data, const Model& other,
                                        Data& other_data, const Eigen::VectorXd& q, int muscle) {
  if (muscle < 0 || muscle >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle) + " is out of range for model '" +
                model.name() + "'");
  }
  // The model's own mode on `data`, the other on the same model in that mode (engine both).
  const WrapMode own = model.description().wrap_mode;
  WrapReportEvaluation own_run = WrapReportEvaluate(model, data, q, muscle);
  WrapReportEvaluation other_run = WrapReportEvaluate(other, other_data, q, muscle);
  const WrapReportEvaluation& os = own == WrapMode::kOpenSim ? own_run : other_run;
  const WrapReportEvaluation& ex = own == WrapMode::kOpenSim ? other_run : own_run;
  WrapModeDifference out;
  out.muscle = muscle;
  out.length_opensim = os.path.length;
  out.status_opensim = os.path.status;
  for (const WrappedPath::Wrap& w : os.path.wraps) out.wraps_engaged += w.wrapped ? 1 : 0;
  out.moment_arm_opensim = os.moment_arm;
  out.length_exact = ex.path.length;
  out.status_exact = ex.path.status;
  out.moment_arm_exact = ex.moment_arm;
  const std::vector<Eigen::Vector3d> points = MusclePathPoints(model, data, q, muscle);
  for (size_t i = 1; i < points.size(); ++i)
    out.length_straight += (points[i] - points[i - 1]).norm();
  for (int c = 0; c < model.dof_count(); ++c) {
    const double diff = std::abs(out.moment_arm_opensim[c] - out.moment_arm_exact[c]);
    if (out.coordinate < 0 || diff > out.moment_arm_difference) {
      out.moment_arm_difference = diff;
      out.coordinate = c;
    }
  }
  return out;
}

}  // namespace

WrapModeDifference CompareWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q,
                                    int muscle) {
  const Model other = ModelInWrapMode(model, OtherWrapMode(model));
  Data other_data(other);
  return CompareWrapModesWith(model, data, other, other_data, q, muscle);
}

std::vector<WrapModeDifference> CompareWrapModes(const Model& model, Data& data,
                                                 const Eigen::VectorXd& q) {
  std::vector<WrapModeDifference> out;
  const std::vector<int> wrapping = WrappingMuscles(model);
  if (wrapping.empty()) return out;
  const Model other = ModelInWrapMode(model, OtherWrapMode(model));
  Data other_data(other);
  for (int m : wrapping) out.push_back(CompareWrapModesWith(model, data, other, other_data, q, m));
  return out;
}

WrapModeSweep SweepWrapModes(const Model& model, Data& data, const Eigen::VectorXd& q0, int muscle,
                             int steps) {
  if (steps < 2) {
    throw Error("a sweep of the wrap modes needs at least 2 values per coordinate, got " +
                std::to_string(steps));
  }
  WrapModeSweep out;
  const Model other = ModelInWrapMode(model, OtherWrapMode(model));
  Data other_data(other);
  auto add = [&](const Eigen::VectorXd& q) {
    const WrapModeDifference d = CompareWrapModesWith(model, data, other, other_data, q, muscle);
    if (out.postures++ == 0) {
      out.at_q0 = d;
      out.max_length_posture = q;
      out.max_moment_arm_posture = q;
    }
    if (std::abs(d.LengthDifference()) > out.max_length_difference) {
      out.max_length_difference = std::abs(d.LengthDifference());
      out.max_length_posture = q;
    }
    if (d.moment_arm_difference > out.max_moment_arm_difference) {
      out.max_moment_arm_difference = d.moment_arm_difference;
      out.max_moment_arm_coordinate = d.coordinate;
      out.max_moment_arm_posture = q;
    }
    const unsigned bad = d.status_opensim & kWrapMisbehaviour;
    if (bad != 0) {
      if (out.misbehaving_postures++ == 0) out.first_misbehaving_posture = q;
      out.misbehaviour |= bad;
    }
  };
  add(q0);
  out.max_moment_arm_coordinate = out.at_q0.coordinate;
  for (int c = 0; c < model.dof_count(); ++c) {
    const CoordinateSpec& spec = model.coordinate(c);
    if (!std::isfinite(spec.lower) || !std::isfinite(spec.upper)) continue;
    Eigen::VectorXd q = q0;
    for (int k = 0; k < steps; ++k) {
      q[c] = spec.lower + (spec.upper - spec.lower) * k / (steps - 1);
      add(q);
    }
  }
  return out;
}

std::string FormatWrapMm(double difference) {
  return util::FormatNumber(std::abs(difference) < kWrapReportNoise ? 0.0 : difference * 1e3, 3);
}

std::vector<int> WrappingMuscles(const Model& model) {
  std::vector<int> out;
  for (int m = 0; m < model.muscle_count(); ++m) {
    if (!model.muscle(m).wraps.empty()) out.push_back(m);
  }
  return out;
}

}  // namespace isowrench
