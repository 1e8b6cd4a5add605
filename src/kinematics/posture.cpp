// Postures in user units (degrees, millimetres) and their validation.

#include "isowrench/posture.hpp"

#include <cmath>

#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench {

void ValidatePosture(const Model& model, const Eigen::VectorXd& q) {
  if (q.size() != model.dof_count()) {
    throw Error("posture has " + std::to_string(q.size()) + " values but model '" + model.name() +
                "' has " + std::to_string(model.dof_count()) + " movable joints (" +
                util::Join(model.joint_names(), ", ") + ")");
  }
  for (int i = 0; i < q.size(); ++i) {
    if (!std::isfinite(q[i])) {
      throw Error("posture of joint '" + model.joint_names()[i] + "' is not finite");
    }
  }
}

double JointValueFromUserUnits(JointType type, double user_value) {
  return type == JointType::kPrismatic ? user_value * 1e-3 : user_value * M_PI / 180.0;
}

double JointValueToUserUnits(JointType type, double model_value) {
  return type == JointType::kPrismatic ? model_value * 1e3 : model_value * 180.0 / M_PI;
}

void SetJointFromUserUnits(const Model& model, Eigen::VectorXd& q, const std::string& joint, double value) {
  int index = model.JointIndex(joint);
  if (!std::isfinite(value)) throw Error("posture of joint '" + joint + "' is not finite");
  q[index] = JointValueFromUserUnits(model.joint(index).type, value);
}

Eigen::VectorXd ApplyPostureAssignments(const Model& model, Eigen::VectorXd q, const std::string& assignments) {
  ValidatePosture(model, q);
  for (const std::string& item : util::Split(assignments, ",; ")) {
    size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error("posture item '" + item + "' is not of the form joint=value (degrees, mm for prismatic)");
    }
    std::string joint = util::Trim(item.substr(0, eq));
    double value = util::ParseDoubleOrThrow(item.substr(eq + 1), "posture of joint '" + joint + "'");
    SetJointFromUserUnits(model, q, joint, value);
  }
  return q;
}

std::string FormatPosture(const Model& model, const Eigen::VectorXd& q, bool all) {
  std::vector<std::string> items;
  for (int i = 0; i < model.dof_count() && i < q.size(); ++i) {
    if (!all && q[i] == 0.0) continue;
    bool prismatic = model.joint(i).type == JointType::kPrismatic;
    double value = JointValueToUserUnits(model.joint(i).type, q[i]);
    items.push_back(model.joint_names()[i] + "=" + util::FormatNumber(value, 6) + (prismatic ? " mm" : "°"));
  }
  return items.empty() ? "all joints at 0" : util::Join(items, ", ");
}

}  // namespace isowrench
