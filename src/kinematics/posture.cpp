// Postures in user units (degrees, millimetres) and their validation.

#include "isowrench/posture.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
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
  // One constant factor: user_value * M_PI / 180 overflowed to inf above 5.7e307 deg.
  return type == JointType::kPrismatic ? user_value * 1e-3 : user_value * (M_PI / 180.0);
}

double JointValueToUserUnits(JointType type, double model_value) {
  return type == JointType::kPrismatic ? model_value * 1e3 : model_value * 180.0 / M_PI;
}

void SetJointFromUserUnits(const Model& model, Eigen::VectorXd& q, const std::string& joint,
                           double value) {
  const CoordinateSpec& coordinate = FindCoordinate(model.description(), joint);
  if (!std::isfinite(value)) throw Error("posture of coordinate '" + joint + "' is not finite");
  const double q_value = JointValueFromUserUnits(coordinate.type, value);
  const bool prismatic = coordinate.type == JointType::kPrismatic;
  if (!(std::abs(q_value) <= (prismatic ? kImpossiblePrismatic : kImpossibleRevolute))) {
    throw Error("posture of coordinate '" + joint + "': " + util::FormatNumber(value) +
                (prismatic ? " mm" : " deg") + " cannot be a joint position (|value| > " +
                util::FormatNumber(JointValueToUserUnits(
                    coordinate.type, prismatic ? kImpossiblePrismatic : kImpossibleRevolute)) +
                (prismatic ? " mm)" : " deg)"));
  }
  q[model.JointIndex(coordinate.name)] = q_value;
}

Eigen::VectorXd ApplyPostureAssignments(const Model& model, Eigen::VectorXd q,
                                        const std::string& assignments) {
  return ApplyPostureAssignments(model, std::move(q), assignments, nullptr);
}

Eigen::VectorXd ApplyPostureAssignments(const Model& model, Eigen::VectorXd q,
                                        const std::string& assignments,
                                        std::vector<std::string>* warnings,
                                        const std::string& label) {
  ValidatePosture(model, q);
  std::map<std::string, std::string> items;  // coordinate -> the item that set it
  for (const std::string& item : util::Split(assignments, ",; ")) {
    size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error("posture item '" + item +
                  "' is not of the form joint=value (degrees, mm for prismatic)");
    }
    std::string joint = util::Trim(item.substr(0, eq));
    double value =
        util::ParseDoubleOrThrow(item.substr(eq + 1), "posture of joint '" + joint + "'");
    SetJointFromUserUnits(model, q, joint, value);
    items[FindCoordinate(model.description(), joint).name] = item;
  }
  if (warnings) warnings->clear();
  if (warnings && !items.empty()) {  // only the values set here (the nominal ones warned at load)
    std::vector<std::string> names;
    for (const auto& entry : items) names.push_back(entry.first);
    *warnings = PostureWarnings(
        model.description(), q,
        [&](const std::string& c) {
          auto it = items.find(c);
          return label + (it == items.end() ? std::string() : " " + it->second);
        },
        names, /*typed_in_user_units=*/true);
  }
  return q;
}

std::vector<Eigen::VectorXd> ParsePostureCsv(const Model& model, const std::string& text,
                                             const std::string& source,
                                             const Eigen::VectorXd& base) {
  ValidatePosture(model, base);
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  std::vector<std::string> names;
  std::vector<const CoordinateSpec*> columns;
  std::vector<Eigen::VectorXd> postures;
  std::vector<bool> warned;  // per column: a plausibility warning was issued
  auto where = [&]() { return source + ":" + std::to_string(line_number) + ": "; };
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    const std::string trimmed = util::Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    std::vector<std::string> fields;
    std::string field;
    std::istringstream cells(line);
    while (std::getline(cells, field, ',')) fields.push_back(util::Trim(field));
    if (line.back() == ',') fields.push_back("");
    if (columns.empty()) {
      for (const std::string& name : fields) {
        if (std::find(names.begin(), names.end(), name) != names.end()) {
          throw Error(where() + "column '" + name + "' appears twice");
        }
        try {
          columns.push_back(&FindCoordinate(model.description(), name));
        } catch (const Error& e) {
          throw Error(where() + "column '" + name + "': " + e.what());
        }
        names.push_back(name);
      }
      warned.assign(columns.size(), false);
      continue;
    }
    if (fields.size() != columns.size()) {
      throw Error(where() + "row has " + std::to_string(fields.size()) +
                  " fields but the header has " + std::to_string(columns.size()) + " (" +
                  util::Join(names, ", ") + ")");
    }
    Eigen::VectorXd q = base;
    for (size_t c = 0; c < columns.size(); ++c) {
      if (fields[c].empty()) continue;
      double value = 0.0;
      if (!util::ParseDouble(fields[c], &value) || !std::isfinite(value)) {
        throw Error(where() + "column '" + names[c] + "': '" + fields[c] +
                    "' is not a finite number (" +
                    (columns[c]->type == JointType::kPrismatic ? "mm" : "degrees") + ")");
      }
      const double q_value = JointValueFromUserUnits(columns[c]->type, value);
      const bool prismatic = columns[c]->type == JointType::kPrismatic;
      if (!(std::abs(q_value) <= (prismatic ? kImpossiblePrismatic : kImpossibleRevolute))) {
        throw Error(where() + "column '" + names[c] + "': " + fields[c] +
                    (prismatic ? " mm" : " deg") + " cannot be a joint position");
      }
      q[model.JointIndex(columns[c]->name)] = q_value;
    }
    // Plausibility (warnings: input_checks.hpp), once per column.
    for (size_t c = 0; c < columns.size(); ++c) {
      if (warned[c] || fields[c].empty()) continue;
      std::vector<std::string> w = PostureWarnings(
          model.description(), q,
          [&](const std::string&) {
            return source + ":" + std::to_string(line_number) + ", column '" + names[c] + "'";
          },
          {columns[c]->name}, /*typed_in_user_units=*/true);
      if (w.empty()) continue;
      warned[c] = true;
      w.back() += " (later rows of this column are not reported)";
      WarnAll(w);
    }
    postures.push_back(q);
  }
  if (postures.empty()) {
    throw Error(
        source +
        ": no posture rows (expected a header naming coordinates, then one row per posture)");
  }
  return postures;
}

std::vector<Eigen::VectorXd> ReadPostureCsv(const Model& model, const std::string& path,
                                            const Eigen::VectorXd& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open posture file '" + path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ParsePostureCsv(model, buffer.str(), path, base);
}

Eigen::Vector3d RollPitchYaw(const Eigen::Matrix3d& R) {
  // The URDF writer's convention (src/model/urdf_writer.cpp Rpy): R = Rz(yaw) Ry(pitch) Rx(roll).
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  double roll = 0.0;
  double yaw = 0.0;
  if (std::abs(std::cos(pitch)) > 1e-9) {
    roll = std::atan2(R(2, 1), R(2, 2));
    yaw = std::atan2(R(1, 0), R(0, 0));
  } else {  // gimbal lock: everything in yaw
    yaw = std::atan2(-R(0, 1), R(1, 1));
  }
  return Eigen::Vector3d(roll, pitch, yaw);
}

std::string FormatRotation(const Eigen::Matrix3d& rotation) {
  const Eigen::Vector3d rpy = RollPitchYaw(rotation);
  if (rpy.cwiseAbs().maxCoeff() < 1e-12) return "not rotated";
  auto n = [](double v) { return util::FormatNumber(std::abs(v) < 1e-12 ? 0.0 : v, 4); };
  const Eigen::Vector3d deg = rpy * 180.0 / M_PI;
  return "rpy " + n(rpy[0]) + " " + n(rpy[1]) + " " + n(rpy[2]) + " rad (" + n(deg[0]) + "° " +
         n(deg[1]) + "° " + n(deg[2]) + "°)";
}

std::string FormatPosture(const Model& model, const Eigen::VectorXd& q, bool all) {
  std::vector<std::string> items;
  for (int i = 0; i < model.dof_count() && i < q.size(); ++i) {
    if (!all && q[i] == 0.0) continue;
    bool prismatic = model.joint(i).type == JointType::kPrismatic;
    double value = JointValueToUserUnits(model.joint(i).type, q[i]);
    items.push_back(model.joint_names()[i] + "=" + util::FormatNumber(value, 6) +
                    (prismatic ? " mm" : "°"));
  }
  return items.empty() ? "all joints at 0" : util::Join(items, ", ");
}

}  // namespace isowrench
