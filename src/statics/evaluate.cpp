// One muscle at one posture on a Model: kinematics + muscle torque + statics + classic answer.

#include <cmath>

#include "isowrench/engine.hpp"
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
  // The activation is checked first, for every force model (the constant one too).
  static_cast<void>(MuscleForceAt(model, muscle_index, 1.0, activation));
  const Data::Impl& k = RunKinematics(model, ws, q, muscle_index, activation, false);
  e.R_W_T = k.TransducerRotation();
  e.jacobian = k.Jacobian();
  e.muscle_length = k.length;
  // The force stage (the one the kernel applied): F(L_MT, a) and its parts.
  e.force = MuscleForceAt(model, muscle_index, k.length, activation);
  e.muscle_force = e.force.force;
  e.tau = k.tau;
  const bool no_equilibrium = e.force.status == MuscleForceStatus::kNoEquilibrium;
  // The passive evaluation: the engine at activation 0 (a constant-force muscle pulls with 0).
  e.passive_force = MuscleForceAt(model, muscle_index, k.length, 0.0);
  if (model.muscle(muscle_index).force.model == ForceModelType::kConstant) {
    e.passive_tau = Eigen::VectorXd::Zero(model.dof_count());
  } else {
    e.passive_tau = RunKinematics(model, ws, q, muscle_index, 0.0, false).tau;
    RunKinematics(model, ws, q, muscle_index, activation, false);  // (ws as the caller expects)
  }
  const StaticsProblem problem(model);
  e.s_t = problem.stiffness().s_t;
  e.s_p = problem.stiffness().s_p;
  for (int c = 0; c < model.dof_count(); ++c) e.locked.push_back(problem.locked(c));
  // Locked coordinates are rigid: the statics and the classic answer run on the columns of K,
  // and dtheta and the self-motion basis are 0 on the locked ones. No equilibrium of the force
  // model: no W (kInvalidInput, zeros), never a number.
  e.statics = problem.Solve(e.jacobian, e.tau, options);
  e.passive_statics = problem.Solve(e.jacobian, e.passive_tau, options);
  if (no_equilibrium) {  // (tau is 0: the solve gave W = 0 with every buffer sized)
    e.statics.status = StaticsStatus::kInvalidInput;
    e.statics.message = "the force model of muscle '" + e.muscle +
                        "' has no equilibrium at its length: W not computed";
    e.passive_statics = e.statics;
  }
  e.classic = problem.Classic(e.jacobian, e.tau);
  e.wrench_world.head<3>() = e.R_W_T * e.statics.wrench.head<3>();
  e.wrench_world.tail<3>() = e.R_W_T * e.statics.wrench.tail<3>();
  return e;
}

std::string ForceModelLabel(const Model& model, int muscle) {
  const MuscleForceModel& f = ForceModelOf(model, muscle);
  if (f.type() == ForceModelType::kConstant) return "constant (F = a x max_force)";
  std::string label = ForceModelName(f.type());
  if (!f.opensim_limitation().empty() && model.muscle(muscle).force.tendon_slack_length == 0.0 &&
      !model.muscle(muscle).force.ignore_tendon_compliance) {
    return label + ", rigid-tendon limit (tendon_slack_length 0: OpenSim gives no number)";
  }
  return label + (f.rigid_tendon() ? ", rigid tendon" : ", compliant tendon");
}

std::string OpenSimNote(const Model& model, int muscle, const MuscleForce& force) {
  if (!force.opensim_gives_no_number) return "";
  const std::string& limitation = ForceModelOf(model, muscle).opensim_limitation();
  if (!limitation.empty()) return "OpenSim gives no number for this muscle: " + limitation;
  return "OpenSim's own equilibrium iteration fails at this length (MuscleCannotEquilibrate); "
         "isowrench's bracketed solve found the equilibrium";
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
