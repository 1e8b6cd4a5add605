// One muscle at one posture on a Model: kinematics + muscle torque + statics + classic answer.

#include <cmath>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "kinematics/kinematics_impl.hpp"
#include "model/model_impl.hpp"
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
  const TransducerSpec& t = model.transducer();
  e.s_t = model.model_stiffness().s_t;
  e.s_p = model.joint_stiffness();
  StaticsOptions opts = options;
  if (opts.leg_length <= 0) opts.leg_length = model.chain_length();
  const FlatChain& chain = model.impl().flat;
  if (!chain.any_locked) {
    e.statics = SolveStatics(e.jacobian, e.s_t, e.s_p, e.tau, opts, model.impl().revolute);
    e.classic = ClassicWrench(e.jacobian, t.released, e.tau);
  } else {
    // Locked coordinates are rigid: the statics and the classic answer run on the free columns,
    // and dtheta and the self-motion basis are 0 on the locked ones.
    std::vector<int> free;
    for (int c = 0; c < chain.n; ++c) {
      if (!chain.locked[c]) free.push_back(c);
    }
    const int f = static_cast<int>(free.size());
    Matrix6Xd J(6, f);
    Eigen::VectorXd s_p(f), tau(f);
    std::vector<bool> revolute(free.size());
    for (int i = 0; i < f; ++i) {
      J.col(i) = e.jacobian.col(free[i]);
      s_p[i] = e.s_p[free[i]];
      tau[i] = e.tau[free[i]];
      revolute[i] = model.impl().revolute[free[i]];
    }
    e.statics = SolveStatics(J, e.s_t, s_p, tau, opts, revolute);
    Eigen::VectorXd dtheta = Eigen::VectorXd::Zero(chain.n);
    Eigen::MatrixXd self_motion = Eigen::MatrixXd::Zero(chain.n, e.statics.self_motion.cols());
    for (int i = 0; i < f; ++i) {
      if (e.statics.dtheta.size() == f) dtheta[free[i]] = e.statics.dtheta[i];
      // .row() of an n x 0 matrix offsets a null pointer (UBSan): copy only a non-empty basis.
      if (e.statics.self_motion.cols() > 0 && e.statics.self_motion.rows() == f) {
        self_motion.row(free[i]) = e.statics.self_motion.row(i);
      }
    }
    e.statics.dtheta = dtheta;
    e.statics.self_motion = self_motion;
    e.classic = ClassicWrench(J, t.released, tau);
  }
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
