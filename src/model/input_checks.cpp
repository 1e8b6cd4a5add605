// Warnings channel, stiffness limits and name suggestions (include/isowrench/input_checks.hpp).

#include "isowrench/input_checks.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <iostream>
#include <map>
#include <mutex>

#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

std::mutex& HandlerMutex() {
  static std::mutex mutex;
  return mutex;
}

WarningHandler& Handler() {
  static WarningHandler handler;
  return handler;
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                  std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

WarningHandler SetWarningHandler(WarningHandler handler) {
  std::lock_guard<std::mutex> lock(HandlerMutex());
  WarningHandler previous = std::move(Handler());
  Handler() = std::move(handler);
  return previous;
}

void Warn(const std::string& message) {
  std::lock_guard<std::mutex> lock(HandlerMutex());
  if (Handler()) {
    Handler()(message);
  } else {
    std::cerr << "isowrench: warning: " << message << "\n";
  }
}

struct WarningCollector::State {
  std::mutex mutex;
  std::vector<std::string> warnings;
};

WarningCollector::WarningCollector() : state_(std::make_shared<State>()) {
  std::shared_ptr<State> state = state_;
  previous_ = SetWarningHandler([state](const std::string& message) {
    std::lock_guard<std::mutex> lock(state->mutex);
    state->warnings.push_back(message);
  });
}

WarningCollector::~WarningCollector() { SetWarningHandler(std::move(previous_)); }

std::vector<std::string> WarningCollector::warnings() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->warnings;
}

std::string WarningCollector::text() const { return util::Join(warnings(), "\n"); }

void CheckStiffnessValue(double stiffness, const std::string& where) {
  if (!std::isfinite(stiffness)) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) + " is not a finite number");
  }
  if (stiffness < 0) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) +
                " is negative; it must be >= 0");
  }
  if (stiffness > kMaxStiffness) {
    throw Error(where + ": stiffness " + util::FormatNumber(stiffness) +
                " exceeds the physical maximum " + util::FormatNumber(kMaxStiffness) +
                " (N/m or N·m/rad; a 1 mm long 10 cm steel bar is 2e12 N/m, see docs/model.md)");
  }
}

namespace {

/// "-3437.75° (-60 rad)" or "870 mm (0.87 m)".
std::string UserAndModelUnits(JointType type, double value) {
  const bool revolute = type != JointType::kPrismatic;
  return util::FormatNumber(JointValueToUserUnits(type, value), 6) + (revolute ? "°" : " mm") +
         " (" + util::FormatNumber(value, 6) + (revolute ? " rad)" : " m)");
}

std::string LengthRange(double lo, double hi) {
  return util::FormatNumber(lo * 1000) + " mm .. " + util::FormatNumber(hi) + " m";
}

bool ImplausibleLength(double length, double lo, double hi) {
  return length > hi || (length > 0 && length < lo);
}

}  // namespace

double LimbLength(const LimbDescription& d) {
  double length = 0.0;
  for (const JointSpec& j : d.joints) length += j.origin.translation().norm();
  return length + d.transducer.endpoint.norm();
}

std::string CoordinateValueWarning(const CoordinateSpec& c, double value, double limb_length,
                                   const std::string& where, bool typed_in_user_units) {
  if (!std::isfinite(value)) return "";  // not a plausibility question: readers refuse it
  const bool revolute = c.type != JointType::kPrismatic;
  std::vector<std::string> why;
  if (value < c.lower || value > c.upper) {
    why.push_back("outside the joint's limits " + UserAndModelUnits(c.type, c.lower) + " .. " +
                  UserAndModelUnits(c.type, c.upper));
  }
  std::string slip;
  if (revolute && std::abs(value) > kFullTurn) {
    why.push_back("more than a full turn");
    slip = typed_in_user_units ? "no limb joint turns that far: a typo, or another column?"
                               : "degrees where radians were meant?";
  } else if (!revolute && limb_length > 0 && std::abs(value) > limb_length) {
    why.push_back("a translation longer than the limb itself (" +
                  util::FormatNumber(limb_length * 1e3, 4) + " mm)");
    slip =
        typed_in_user_units ? "a typo, or another column?" : "millimetres where metres were meant?";
  }
  if (why.empty()) return "";
  return where + ": " + c.name + " = " + UserAndModelUnits(c.type, value) + " is " +
         util::Join(why, " and ") + (slip.empty() ? std::string() : " (" + slip + ")");
}

std::vector<std::string> PostureWarnings(
    const LimbDescription& d, const Eigen::VectorXd& q,
    const std::function<std::string(const std::string&)>& where,
    const std::vector<std::string>& only, bool typed_in_user_units) {
  if (q.size() != static_cast<Eigen::Index>(d.coordinates.size())) {
    throw Error("posture has " + std::to_string(q.size()) + " values but the limb has " +
                std::to_string(d.coordinates.size()) + " coordinates");
  }
  auto place = [&](const std::string& name) { return where ? where(name) : "posture"; };
  auto checked = [&](const std::string& name) {
    return only.empty() || std::find(only.begin(), only.end(), name) != only.end();
  };
  const double limb = LimbLength(d);
  std::vector<std::string> out;
  std::map<std::string, Eigen::Index> column;
  for (size_t i = 0; i < d.coordinates.size(); ++i) {
    const CoordinateSpec& c = d.coordinates[i];
    column[c.name] = static_cast<Eigen::Index>(i);
    if (!checked(c.name)) continue;
    std::string w = CoordinateValueWarning(c, q[static_cast<Eigen::Index>(i)], limb, place(c.name),
                                           typed_in_user_units);
    if (!w.empty()) out.push_back(w);
  }
  // Joints driven through a coupling: their value at q is the function's, not the user's.
  for (const JointSpec& j : d.joints) {
    if (j.type == JointType::kFixed || j.coordinate.empty() || !checked(j.coordinate)) continue;
    if (j.coordinate == j.name && j.coupling.is_identity()) continue;
    auto c = column.find(j.coordinate);
    if (c == column.end()) continue;
    const CoordinateSpec& driver = d.coordinates[static_cast<size_t>(c->second)];
    const double x = q[c->second];
    const double value = j.coupling.Value(x);
    if (!std::isfinite(value)) continue;
    const std::string at = "joint '" + j.name + "', driven by " + driver.name + " = " +
                           UserAndModelUnits(driver.type, x) + ", is " +
                           UserAndModelUnits(j.type, value);
    if (j.type == JointType::kRevolute && std::abs(value) > kFullTurn) {
      out.push_back(place(driver.name) + ": " + at +
                    ", more than a full turn (a coupling written in degrees, or its "
                    "multiplier in the wrong unit?)");
    } else if (j.type == JointType::kPrismatic && limb > 0 && std::abs(value) > limb) {
      out.push_back(place(driver.name) + ": " + at + ", which moves the endpoint " +
                    util::FormatNumber(std::abs(value) * 1e3, 4) +
                    " mm, more than the limb's own length " + util::FormatNumber(limb * 1e3, 4) +
                    " mm (a <mimic> multiplier or coupling in m/rad where mm/rad was meant, i.e. "
                    "1000 times too large?)");
    }
  }
  return out;
}

std::string RotationWarning(const Eigen::Vector3d& rpy, const std::string& what) {
  if (!(rpy.cwiseAbs().maxCoeff() > kFullTurn)) return "";
  const Eigen::Vector3d as_degrees = rpy * 3.14159265358979323846 / 180.0;
  return what + " = " + util::FormatNumber(rpy[0]) + " " + util::FormatNumber(rpy[1]) + " " +
         util::FormatNumber(rpy[2]) +
         " rad turns more than a full turn about an axis: degrees written where radians are "
         "meant? (URDF angles are radians; read as degrees these are " +
         util::FormatNumber(as_degrees[0], 4) + " " + util::FormatNumber(as_degrees[1], 4) + " " +
         util::FormatNumber(as_degrees[2], 4) + " rad)";
}

std::vector<std::string> DescriptionWarnings(
    const LimbDescription& d, const std::function<std::string(const std::string&)>& where) {
  auto place = [&](const std::string& name) {
    if (where) return where(name);
    return d.source.empty() ? std::string("limb '") + d.name + "'" : d.source;
  };
  std::vector<std::string> out;
  // Segment lengths: joint origin offsets (a chain of co-located joints has length 0).
  std::map<std::string, Eigen::Isometry3d> frame;  // link -> world pose at the nominal posture
  frame[d.root_link] = Eigen::Isometry3d::Identity();
  std::map<std::string, double> nominal;
  for (const CoordinateSpec& c : d.coordinates) nominal[c.name] = c.default_value;
  for (const auto& [name, value] : d.nominal_posture) nominal[name] = value;
  for (const JointSpec& j : d.joints) {
    const double length = j.origin.translation().norm();
    if (ImplausibleLength(length, kMinSegmentLength, kMaxSegmentLength)) {
      out.push_back(place(j.name) + ": joint '" + j.name + "' sits " + util::FormatNumber(length) +
                    " m from the origin of link '" + j.parent_link +
                    "', outside the plausible segment length of a limb (" +
                    LengthRange(kMinSegmentLength, kMaxSegmentLength) +
                    "); URDF lengths are in metres");
    }
    double q = 0;
    if (j.type != JointType::kFixed) {
      const std::string& driver = j.coordinate.empty() ? j.name : j.coordinate;
      auto it = nominal.find(driver);
      const double x = it == nominal.end() ? 0.0 : it->second;
      q = j.coordinate.empty() ? x : j.coupling.Value(x);
    }
    Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
    if (j.type == JointType::kRevolute)
      motion.linear() = Eigen::AngleAxisd(q, j.axis).toRotationMatrix();
    if (j.type == JointType::kPrismatic) motion.translation() = q * j.axis;
    auto parent = frame.find(j.parent_link);
    if (parent != frame.end()) frame[j.child_link] = parent->second * j.origin * motion;
  }
  const double endpoint = d.transducer.endpoint.norm();
  if (ImplausibleLength(endpoint, kMinSegmentLength, kMaxSegmentLength)) {
    out.push_back(place("") + ": the endpoint sits " + util::FormatNumber(endpoint) +
                  " m from the origin of link '" + d.transducer.link +
                  "', outside the plausible segment length of a limb (" +
                  LengthRange(kMinSegmentLength, kMaxSegmentLength) + "); lengths are in metres");
  }
  for (const MuscleSpec& m : d.muscles) {
    double length = 0;
    bool known = true;
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < m.path.size(); ++i) {
      auto f = frame.find(m.path[i].link);
      if (f == frame.end() || !m.path[i].position.allFinite()) {
        known = false;
        break;
      }
      const Eigen::Vector3d p = f->second * m.path[i].position;
      if (i > 0) length += (p - previous).norm();
      previous = p;
    }
    if (known && std::isfinite(length) &&
        (length < kMinMuscleLength || length > kMaxMuscleLength)) {
      out.push_back(place("muscle:" + m.name) + ": muscle '" + m.name + "' is " +
                    util::FormatNumber(length) +
                    " m long at the nominal posture, outside the plausible muscle length of a "
                    "limb (" +
                    LengthRange(kMinMuscleLength, kMaxMuscleLength) + "); lengths are in metres");
    }
  }
  // The nominal posture, where the coordinates are consistent (a description built in code may
  // not have them yet; Model normalizes it).
  if (!d.coordinates.empty()) {
    Eigen::VectorXd q(static_cast<Eigen::Index>(d.coordinates.size()));
    for (size_t i = 0; i < d.coordinates.size(); ++i) {
      q[static_cast<Eigen::Index>(i)] = nominal[d.coordinates[i].name];
    }
    auto posture_place = [&](const std::string& c) { return place("posture:" + c); };
    for (std::string& w : PostureWarnings(d, q, posture_place)) out.push_back(std::move(w));
  }
  return out;
}

void WarnAll(const std::vector<std::string>& messages) {
  for (const std::string& m : messages) Warn(m);
}

std::string ClosestName(const std::string& name, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::max<size_t>(2, name.size() / 3) + 1;
  for (const std::string& c : candidates) {
    size_t d = EditDistance(name, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::string DidYouMean(const std::string& name, const std::vector<std::string>& candidates) {
  std::string best = ClosestName(name, candidates);
  return best.empty() ? std::string() : " (did you mean '" + best + "'?)";
}

}  // namespace isowrench
