// The candidate effect library: which effects apply to a model, and how each edits a
// LimbDescription (or post-processes the predicted wrench).

#include <algorithm>
#include <cmath>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;
constexpr double kMillimetre = 1e-3;
/// Joints whose origins are closer than this (m) belong to one group (a ball/universal joint).
constexpr double kColocated = 1e-9;
/// An axis is already covered by a group when |cos(angle)| with one of its axes exceeds this.
constexpr double kCoveredAxis = 0.9;

EffectParameter LogParameter(const std::string& name, const std::string& unit, double neutral,
                             double initial, double lower, double upper) {
  EffectParameter p;
  p.name = name;
  p.unit = unit;
  p.scale = ParameterScale::kLog10;
  p.neutral = neutral;
  p.initial = initial;
  p.lower = lower;
  p.upper = upper;
  return p;
}

EffectParameter LinearParameter(const std::string& name, const std::string& unit, double range) {
  EffectParameter p;
  p.name = name;
  p.unit = unit;
  p.scale = ParameterScale::kLinear;
  p.neutral = 0.0;
  p.initial = 0.0;
  p.lower = -range;
  p.upper = range;
  return p;
}

const char* kAxisNames[3] = {"x", "y", "z"};

double MeanTranslational(const Model& model) {
  double k = model.transducer().stiffness.head<3>().mean();
  return k > 0 ? k : 1e7;
}

/// Rotational stiffness of the transducer felt by a unit rotation about an extra joint at the
/// nominal posture: j^T S_t j (N·m/rad), the scale the extra joint's stiffness is compared to.
double ExtraJointScale(const Model& model, const std::string& joint, const Eigen::Vector3d& axis) {
  try {
    LimbDescription d = WithExtraJoint(model.description(), joint, "isowrench_probe", axis, 1.0);
    Model probe(d);
    KinematicsWorkspace ws(probe);
    Eigen::VectorXd q = probe.nominal_posture();
    Matrix6Xd J = EndpointJacobian(probe, ws, q);
    Eigen::VectorXd j = J.col(probe.JointIndex("isowrench_probe"));
    Vector6d s_t = probe.transducer().stiffness;
    for (int i = 0; i < 6; ++i) {
      if (probe.transducer().released[i]) s_t[i] = 0;
    }
    double k = j.dot(s_t.asDiagonal() * j);
    if (std::isfinite(k) && k > 0) return k;
  } catch (const Error&) {
  }
  return 1.0;
}

}  // namespace

namespace ident {

std::uint64_t Random::Next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double Random::Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

double Random::Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

double Random::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1 = 0.0;
  do {
    u1 = Uniform();
  } while (u1 <= 0.0);
  double u2 = Uniform();
  double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2 * kPi * u2);
  has_spare_ = true;
  return r * std::cos(2 * kPi * u2);
}

double ToInternal(const EffectParameter& p, double user) {
  return p.scale == ParameterScale::kLog10 ? std::log10(user) : user;
}

double ToUser(const EffectParameter& p, double internal) {
  return p.scale == ParameterScale::kLog10 ? std::pow(10.0, internal) : internal;
}

std::string ConflictKey(const Effect& effect) {
  switch (effect.kind) {
    case EffectKind::kBaseIsotropic:
    case EffectKind::kBasePerAxis:
      return "base";
    default:
      return effect.id;
  }
}

}  // namespace ident

const char* EffectKindName(EffectKind kind) {
  switch (kind) {
    case EffectKind::kBaseIsotropic: return "base_isotropic";
    case EffectKind::kBasePerAxis: return "base_per_axis";
    case EffectKind::kExtraJoint: return "extra_joint";
    case EffectKind::kTransducerAnisotropy: return "transducer_anisotropy";
    case EffectKind::kTransducerSoftDof: return "transducer_soft";
    case EffectKind::kTransducerMisalignment: return "misalignment";
    case EffectKind::kSensorOffset: return "sensor_offset";
    case EffectKind::kMuscleForceScale: return "force_scale";
    case EffectKind::kAttachmentOffset: return "attachment";
    case EffectKind::kMomentReferenceOffset: return "moment_reference";
  }
  return "?";
}

std::vector<Effect> CandidateEffects(const Model& model, const std::vector<std::string>& muscles) {
  std::vector<Effect> out;
  const LimbDescription& d = model.description();
  const double k_trans = MeanTranslational(model);

  bool has_base = false;
  for (const JointSpec& j : d.joints) has_base |= j.role == JointRole::kBase;
  if (!has_base) {
    Effect e;
    e.kind = EffectKind::kBaseIsotropic;
    e.id = "base_isotropic";
    e.description = "imperfect skeletal fixation: one stiffness for the base translations x y z";
    e.parameters.push_back(LogParameter("k_base", "N/m", 1e4 * k_trans, k_trans, 1e-4 * k_trans, 1e4 * k_trans));
    out.push_back(e);
    Effect a;
    a.kind = EffectKind::kBasePerAxis;
    a.id = "base_per_axis";
    a.description = "imperfect skeletal fixation: a stiffness per world axis for the base translations";
    for (int i = 0; i < 3; ++i) {
      a.parameters.push_back(LogParameter(std::string("k_base_") + kAxisNames[i], "N/m", 1e4 * k_trans, k_trans,
                                          1e-4 * k_trans, 1e4 * k_trans));
    }
    out.push_back(a);
  }

  // Extra joint dofs: for each group of co-located revolute joints, each missing axis.
  std::vector<const JointSpec*> movable;
  for (const JointSpec& j : d.joints) {
    if (j.type != JointType::kFixed) movable.push_back(&j);
  }
  for (size_t start = 0; start < movable.size();) {
    size_t stop = start + 1;
    while (stop < movable.size() && movable[stop]->origin.translation().norm() < kColocated &&
           movable[stop]->type == JointType::kRevolute) {
      ++stop;
    }
    if (movable[start]->type == JointType::kRevolute && movable[start]->role == JointRole::kLimb) {
      // Axes of the group expressed in the child frame of its last joint at q = 0.
      std::vector<Eigen::Vector3d> axes;
      Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // frame of joint k in the last child frame
      for (size_t k = stop; k-- > start;) {
        axes.push_back(R * movable[k]->axis);
        if (k > start) R = R * movable[k]->origin.linear().transpose();
      }
      const JointSpec& last = *movable[stop - 1];
      for (int a = 0; a < 3; ++a) {
        Eigen::Vector3d axis = Eigen::Vector3d::Unit(a);
        bool covered = false;
        for (const Eigen::Vector3d& g : axes) covered |= std::abs(g.normalized().dot(axis)) > kCoveredAxis;
        if (covered) continue;
        Effect e;
        e.kind = EffectKind::kExtraJoint;
        e.joint = last.name;
        e.axis = axis;
        e.id = "extra_joint:" + last.name + ":" + kAxisNames[a];
        e.description = std::string("an extra revolute dof about ") + kAxisNames[a] + " after joint " +
                        last.name + ", held by a passive stiffness";
        double scale = ExtraJointScale(model, last.name, axis);
        e.parameters.push_back(
            LogParameter("k_joint", "N·m/rad", 1e4 * scale, scale, 1e-6 * scale, 1e4 * scale));
        out.push_back(e);
      }
    }
    start = stop;
  }

  {
    Effect e;
    e.kind = EffectKind::kTransducerAnisotropy;
    e.id = "transducer_anisotropy";
    e.description = "transducer rotational stiffness differs from the stated one by a factor "
                    "(translation/rotation stiffness ratio)";
    e.parameters.push_back(LogParameter("rotation_factor", "x", 1.0, 1.0, 1e-4, 1e4));
    out.push_back(e);
  }
  for (int dof = 0; dof < 6; ++dof) {
    const TransducerSpec& t = d.transducer;
    if (t.released[dof] || !(t.stiffness[dof] > 0)) continue;
    Effect e;
    e.kind = EffectKind::kTransducerSoftDof;
    e.dof = dof;
    e.id = std::string("transducer_soft:") + DofName(dof);
    e.description = std::string("transducer dof ") + DofName(dof) + " partially released (low stiffness)";
    double k = t.stiffness[dof];
    e.parameters.push_back(LogParameter(std::string("k_") + DofName(dof), dof < 3 ? "N/m" : "N·m/rad", k, 0.1 * k,
                                        1e-6 * k, 1e2 * k));
    out.push_back(e);
  }
  {
    Effect e;
    e.kind = EffectKind::kTransducerMisalignment;
    e.id = "misalignment";
    e.description = "transducer axes rotated by a small rotation (rotation vector in transducer axes)";
    for (const char* n : {"rx", "ry", "rz"}) e.parameters.push_back(LinearParameter(n, "deg", 20.0));
    out.push_back(e);
  }
  {
    Effect e;
    e.kind = EffectKind::kSensorOffset;
    e.id = "sensor_offset";
    e.description = "constant offset wrench added to every reading (zeroing error, drift)";
    e.post_processing = true;
    for (const char* n : {"fx", "fy", "fz"}) e.parameters.push_back(LinearParameter(n, "N", 10.0));
    for (const char* n : {"mx", "my", "mz"}) e.parameters.push_back(LinearParameter(n, "N·m", 1.0));
    out.push_back(e);
  }
  for (const MuscleSpec& m : d.muscles) {
    if (!muscles.empty() && std::find(muscles.begin(), muscles.end(), m.name) == muscles.end()) continue;
    Effect e;
    e.kind = EffectKind::kMuscleForceScale;
    e.id = "force_scale:" + m.name;
    e.muscle = m.name;
    e.description = "muscle " + m.name + " force differs from max_force by a factor";
    e.post_processing = true;
    e.parameters.push_back(LogParameter("scale", "x", 1.0, 1.0, 1e-2, 1e2));
    out.push_back(e);
  }
  for (const MuscleSpec& m : d.muscles) {
    if (!muscles.empty() && std::find(muscles.begin(), muscles.end(), m.name) == muscles.end()) continue;
    for (size_t p = 0; p < m.path.size(); ++p) {
      Effect e;
      e.kind = EffectKind::kAttachmentOffset;
      e.muscle = m.name;
      e.point = static_cast<int>(p);
      e.id = "attachment:" + m.name + ":" + std::to_string(p);
      e.description = "muscle " + m.name + " path point " + std::to_string(p) + " (on " + m.path[p].link +
                      (p == 0 ? ", origin" : p + 1 == m.path.size() ? ", insertion" : "") +
                      ") displaced, in the link's frame";
      for (const char* n : {"dx", "dy", "dz"}) e.parameters.push_back(LinearParameter(n, "mm", 10.0));
      out.push_back(e);
    }
  }
  {
    Effect e;
    e.kind = EffectKind::kMomentReferenceOffset;
    e.id = "moment_reference";
    e.description = "moment reference point (endpoint) displaced, in the endpoint link's frame";
    for (const char* n : {"dx", "dy", "dz"}) e.parameters.push_back(LinearParameter(n, "mm", 20.0));
    out.push_back(e);
  }
  return out;
}

Effect FindEffect(const Model& model, const std::string& id) {
  std::vector<Effect> all = CandidateEffects(model);
  std::vector<std::string> ids;
  for (const Effect& e : all) {
    if (e.id == id) return e;
    ids.push_back(e.id);
  }
  throw Error("unknown effect '" + id + "' for model '" + model.name() + "' (known: " + util::Join(ids, ", ") + ")");
}

LimbDescription ApplyEffect(LimbDescription d, const Effect& effect, const std::vector<double>& values) {
  if (values.size() != effect.parameters.size()) {
    throw Error("effect '" + effect.id + "' takes " + std::to_string(effect.parameters.size()) +
                " value(s), got " + std::to_string(values.size()));
  }
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]) ||
        (effect.parameters[i].scale == ParameterScale::kLog10 && !(values[i] > 0))) {
      throw Error("effect '" + effect.id + "': parameter " + effect.parameters[i].name + " = " +
                  util::FormatNumber(values[i]) + " must be finite" +
                  (effect.parameters[i].scale == ParameterScale::kLog10 ? " and > 0" : ""));
    }
  }
  switch (effect.kind) {
    case EffectKind::kBaseIsotropic:
      return WithBaseStiffness(std::move(d), values[0]);
    case EffectKind::kBasePerAxis: {
      d = WithBaseStiffness(std::move(d), values[0]);
      int axis = 0;
      for (JointSpec& j : d.joints) {
        if (j.role == JointRole::kBase && j.type == JointType::kPrismatic) {
          // base joints translate along world x, y, z in that order (WithBaseStiffness)
          int k = 0;
          j.axis.cwiseAbs().maxCoeff(&k);
          j.stiffness = values[k];
          ++axis;
        }
      }
      return d;
    }
    case EffectKind::kExtraJoint: {
      int a = 0;
      effect.axis.cwiseAbs().maxCoeff(&a);
      std::string name = effect.joint + "_extra_r" + kAxisNames[a];
      return WithExtraJoint(std::move(d), effect.joint, name, effect.axis, values[0]);
    }
    case EffectKind::kTransducerAnisotropy: {
      Vector6d s = d.transducer.stiffness;
      s.tail<3>() *= values[0];
      return WithTransducerStiffness(std::move(d), s);
    }
    case EffectKind::kTransducerSoftDof: {
      Vector6d s = d.transducer.stiffness;
      s[effect.dof] = values[0];
      return WithTransducerStiffness(std::move(d), s);
    }
    case EffectKind::kTransducerMisalignment: {
      Eigen::Vector3d v(values[0], values[1], values[2]);
      v *= kDegree;
      if (v.norm() > 0) {
        d.transducer.rotation = d.transducer.rotation * Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix();
      }
      return d;
    }
    case EffectKind::kSensorOffset:
      return d;
    case EffectKind::kMuscleForceScale:
      for (MuscleSpec& m : d.muscles) {
        if (m.name == effect.muscle) {
          m.max_force *= values[0];
          return d;
        }
      }
      throw Error("effect '" + effect.id + "': unknown muscle '" + effect.muscle + "'");
    case EffectKind::kAttachmentOffset:
      for (MuscleSpec& m : d.muscles) {
        if (m.name != effect.muscle) continue;
        if (effect.point < 0 || effect.point >= static_cast<int>(m.path.size())) break;
        m.path[effect.point].position += Eigen::Vector3d(values[0], values[1], values[2]) * kMillimetre;
        return d;
      }
      throw Error("effect '" + effect.id + "': muscle '" + effect.muscle + "' has no path point " +
                  std::to_string(effect.point));
    case EffectKind::kMomentReferenceOffset:
      d.transducer.endpoint += Eigen::Vector3d(values[0], values[1], values[2]) * kMillimetre;
      return d;
  }
  return d;
}

AugmentedModel ApplyEffects(const LimbDescription& nominal, const std::vector<AppliedEffect>& effects) {
  AugmentedModel out;
  out.description = nominal;
  for (const AppliedEffect& a : effects) {
    out.description = ApplyEffect(std::move(out.description), a.effect, a.values);
    if (a.effect.kind == EffectKind::kSensorOffset) {
      for (int i = 0; i < 6; ++i) out.sensor_offset[i] += a.values[i];
    }
    out.effects.push_back(a);
  }
  return out;
}

AppliedEffect ParseEffectAssignment(const Model& model, const std::string& text) {
  size_t eq = text.find('=');
  if (eq == std::string::npos) {
    throw Error("effect '" + text + "': expected NAME=VALUE[,VALUE...] (user units, see docs/identification.md)");
  }
  std::string id = util::Trim(text.substr(0, eq));
  AppliedEffect out;
  out.effect = FindEffect(model, id);
  std::vector<std::string> pieces = util::Split(text.substr(eq + 1), ",");
  for (const std::string& p : pieces) {
    out.values.push_back(util::ParseDoubleOrThrow(p, "effect '" + id + "'"));
  }
  if (out.values.size() != out.effect.parameters.size()) {
    std::vector<std::string> names;
    for (const EffectParameter& p : out.effect.parameters) names.push_back(p.name + " (" + p.unit + ")");
    throw Error("effect '" + id + "' takes " + std::to_string(out.effect.parameters.size()) +
                " value(s): " + util::Join(names, ", ") + "; got " + std::to_string(out.values.size()));
  }
  // Validate now so the error names the effect.
  ApplyEffect(model.description(), out.effect, out.values);
  return out;
}

}  // namespace isowrench
