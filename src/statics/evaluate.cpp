// One muscle at one posture on a Model: kinematics + muscle torque + statics + classic answer.

#include <cmath>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "kinematics/kinematics_impl.hpp"
#include "util/text.hpp"

namespace isowrench {

WrenchEvaluation EvaluateWrench(const Model& model, const Eigen::VectorXd& q,
                                const std::string& muscle, double activation,
                                const StaticsOptions& options) {
  int muscle_index = model.MuscleIndex(muscle);
  Data ws(model);
  return EvaluateWrench(model, ws, q, muscle_index, activation, options);
}

WrenchEvaluation EvaluateWrench(const Model& model, Data& ws, const Eigen::VectorXd& q,
                                int muscle_index, double activation,
                                const StaticsOptions& options) {
  if (muscle_index < 0 || muscle_index >= model.muscle_count()) {
    throw Error("muscle index " + std::to_string(muscle_index) + " is out of range for model '" +
                model.name() + "'");
  }
  ValidatePosture(model, q);
  WrenchEvaluation e;
  e.q = q;
  e.muscle = model.muscle(muscle_index).name;
  // One run of the kinematics kernel: J in transducer axes, R_W_T and the muscle torque.
  const Data::Impl& k = RunKinematics(model, ws, q, muscle_index, activation, false);
  e.R_W_T = k.TransducerRotation();
  e.jacobian = k.Jacobian();
  e.muscle_length = k.length;
  e.muscle_force = activation * model.muscle(muscle_index).max_force;
  e.tau = k.tau;
  const StaticsProblem problem(model);
  e.s_t = problem.stiffness().s_t;
  e.s_p = problem.stiffness().s_p;
  for (int c = 0; c < model.dof_count(); ++c) e.locked.push_back(problem.locked(c));
  // Locked coordinates are rigid: the statics and the classic answer run on the columns of K,
  // and dtheta and the self-motion basis are 0 on the locked ones.
  e.statics = problem.Solve(e.jacobian, e.tau, options);
  e.classic = problem.Classic(e.jacobian, e.tau);
  e.wrench_world.head<3>() = e.R_W_T * e.statics.wrench.head<3>();
  e.wrench_world.tail<3>() = e.R_W_T * e.statics.wrench.tail<3>();
  return e;
}

std::string DescribeJointMotion(const Model& model, const Eigen::VectorXd& direction,
                                double cutoff) {
  if (direction.size() != model.dof_count() || !direction.allFinite()) return "(invalid direction)";
  double largest = direction.cwiseAbs().maxCoeff();
  if (largest == 0.0) return "(zero)";
  Eigen::VectorXd v = direction / largest;
  std::vector<std::string> items;
  for (int i = 0; i < v.size(); ++i) {
    if (std::abs(v[i]) < cutoff) continue;
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%+.2f", v[i]);
    std::string text = model.joint_names()[i] + " " + buffer;
    if (model.joint(i).type == JointType::kPrismatic) text += " (m)";
    items.push_back(text);
  }
  return util::Join(items, ", ");
}

}  // namespace isowrench
