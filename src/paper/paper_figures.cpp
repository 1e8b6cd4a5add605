// The paper's Figures 2-4 recomputed from the shipped rat URDFs (docs/paper.md lists the
// stiffness values the paper leaves unstated and the ones chosen here).

#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/paper.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

// Transducer translational stiffness of the paper's balanced case (N/m) and, with the same
// number, rotational stiffness (N·m/rad).
constexpr double kBalanced = 1e7;
// Fig. 2 rows C and D: rotational stiffness reduced to 0.01 and 0.0001 of the translational.
constexpr double kMomentRatioC = 1e-2;
constexpr double kMomentRatioD = 1e-4;
// Fig. 3 base stiffness rows B (high), C and D (N/m); Fig. 4 C uses the "moderate" value.
constexpr double kBaseHigh = 1e9;
constexpr double kBaseModerate = 1e7;
constexpr double kBaseLow = 1e5;
// Fig. 4: knee ab/adduction stiffness (N·m/rad), from the paper.
constexpr double kKneeAbduction = 1.0;

const char* kReleased = "released rz (5 forces)";
const char* kOverConstrained = "over-constrained (6 forces)";

std::string Stiffness(const Vector6d& s) {
  return "S_t = [" + util::FormatNumber(s[0], 4) + " " + util::FormatNumber(s[1], 4) + " " +
         util::FormatNumber(s[2], 4) + " N/m, " + util::FormatNumber(s[3], 4) + " " +
         util::FormatNumber(s[4], 4) + " " + util::FormatNumber(s[5], 4) + " N·m/rad]";
}

Vector6d MomentRatio(double ratio) {
  Vector6d s = Vector6d::Constant(kBalanced);
  s.tail<3>() *= ratio;
  return s;
}

struct Case {
  const Model* model;
  bool release_rz;
};

LimbDescription Configure(const Model& base, bool release_rz, const Vector6d& s_t,
                          double base_stiffness) {
  LimbDescription d = WithReleasedDofs(base.description(), release_rz ? DofMask{"rz"} : DofMask{});
  d = WithTransducerStiffness(std::move(d), s_t);
  if (base_stiffness > 0) d = WithBaseStiffness(std::move(d), base_stiffness);
  return d;
}

PaperPanel Eq10Panel(int figure, const std::string& row, const Model& base, bool release_rz,
                     const Vector6d& s_t, double base_stiffness, const std::string& condition) {
  Model model(Configure(base, release_rz, s_t, base_stiffness));
  WrenchEvaluation e = EvaluateWrench(model, model.nominal_posture(), "GP");
  PaperPanel p;
  p.figure = figure;
  p.row = row;
  p.column = release_rz ? kReleased : kOverConstrained;
  p.method = "Eq. 10";
  p.s_t = e.s_t;
  p.base_stiffness = base_stiffness;
  p.condition =
      condition + "; " + Stiffness(s_t) +
      (base_stiffness > 0 ? "; base " + util::FormatNumber(base_stiffness, 3) + " N/m" : "") +
      (base.description().name == "rat_hindlimb_6dof"
           ? "; knee ab/adduction " +
                 util::FormatNumber(model.joint(model.JointIndex("knee_ry")).stiffness, 3) +
                 " N·m/rad"
           : "");
  p.wrench = e.statics.wrench;
  p.valid = e.statics.ok() && e.statics.small_motion_valid;
  if (!e.statics.ok()) {
    p.note = e.statics.message;
  } else if (!e.statics.small_motion_valid) {
    p.note = e.statics.validity_message;
  }
  return p;
}

PaperPanel ClassicPanel(int figure, const Model& base, bool release_rz) {
  Model model(Configure(base, release_rz, Vector6d::Constant(kBalanced), 0.0));
  WrenchEvaluation e = EvaluateWrench(model, model.nominal_posture(), "GP");
  PaperPanel p;
  p.figure = figure;
  p.row = "A";
  p.column = release_rz ? kReleased : kOverConstrained;
  p.method = e.classic.square_inverse ? "J^-T tau (Eq. 11)" : "pinv(J^T) tau (Eq. 15)";
  p.condition =
      e.classic.square_inverse ? "simple inverse, no compliance" : "pseudoinverse, no compliance";
  p.wrench = e.classic.wrench;
  return p;
}

Model LoadRat(const std::string& urdf_dir, const std::string& file) {
  return Model::FromUrdfFile(urdf_dir + "/" + file);
}

}  // namespace

std::string DefaultUrdfDirectory() {
  if (const char* env = std::getenv("ISOWRENCH_URDF_DIR")) return env;
  std::vector<std::string> candidates = {ISOWRENCH_SOURCE_URDF_DIR};
  // An installed tool finds <prefix>/share/isowrench/urdf next to <prefix>/bin, wherever the
  // prefix was moved to (cmake --install --prefix differs from the configured one).
  char exe[4096];
  ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n > 0) {
    std::string path(exe, static_cast<size_t>(n));
    size_t slash = path.rfind('/');
    if (slash != std::string::npos)
      candidates.push_back(path.substr(0, slash) + "/../share/isowrench/urdf");
  }
  candidates.push_back(ISOWRENCH_INSTALL_URDF_DIR);
  for (const std::string& dir : candidates) {
    std::ifstream probe(dir + "/rat_hindlimb_5dof.urdf");
    if (probe) return dir;
  }
  return "urdf";
}

Vector6d FemurRemovedWrench(const Model& model, const Eigen::VectorXd& q,
                            const std::string& muscle_name, double activation) {
  const MuscleSpec& muscle = model.muscle(model.MuscleIndex(muscle_name));
  Data ws(model);
  const std::string& tibia = model.transducer().link;
  Eigen::Vector3d endpoint = EndpointPose(model, ws, q).translation();
  // The force stage at this posture (a x max_force for the paper's constant-force muscles).
  const double force =
      ComputeMuscleTorque(model, ws, q, model.MuscleIndex(muscle_name), activation).force;
  Vector6d w_world = Vector6d::Zero();
  auto add = [&](const Eigen::Vector3d& at, const Eigen::Vector3d& f) {
    w_world.head<3>() += f;
    w_world.tail<3>() += (at - endpoint).cross(f);
  };
  // The engine's path (moving and conditional points, and wraps: a tangent point is a point of
  // its wrap object's link; the arc between a wrap's two tangent points pulls nothing).
  const int index = model.MuscleIndex(muscle_name);
  const WrappedPath path = MuscleWrappedPath(model, ws, q, index);
  auto link_of = [&](const WrappedPath::Element& e) -> const std::string& {
    if (e.point >= 0) return muscle.path[static_cast<size_t>(e.point)].link;
    const std::string& object = muscle.wraps[static_cast<size_t>(e.wrap)].object;
    for (const WrapObjectSpec& w : model.description().wrap_objects) {
      if (w.name == object) return w.link;
    }
    throw Error("muscle '" + muscle.name + "': no wrap object '" + object + "'");
  };
  for (size_t i = 1; i < path.elements.size(); ++i) {
    const WrappedPath::Element& a = path.elements[i - 1];
    const WrappedPath::Element& b = path.elements[i];
    if (a.wrap >= 0 && a.wrap == b.wrap && a.end == 0 && b.end == 1) continue;  // the arc
    const std::string& link_a = link_of(a);
    const std::string& link_b = link_of(b);
    Eigen::Vector3d u = (b.position - a.position).normalized();  // from a toward b
    // The segment pulls each of its ends toward the other; the tibia passes what it receives
    // to the transducer (W = what the limb applies to the transducer).
    if (link_b == tibia && link_a != tibia) add(b.position, -force * u);
    if (link_a == tibia && link_b != tibia) add(a.position, force * u);
  }
  Eigen::Matrix3d R = TransducerRotation(model, ws, q);
  Vector6d w;
  w.head<3>() = R.transpose() * w_world.head<3>();
  w.tail<3>() = R.transpose() * w_world.tail<3>();
  return w;
}

std::vector<PaperPanel> ComputePaperFigure(int figure, const std::string& urdf_dir) {
  std::vector<PaperPanel> panels;
  if (figure == 2 || figure == 3) {
    Model rat = LoadRat(urdf_dir, "rat_hindlimb_5dof.urdf");
    for (bool release : {true, false}) panels.push_back(ClassicPanel(figure, rat, release));
    if (figure == 2) {
      struct Row {
        const char* row;
        const char* condition;
        Vector6d s_t;
      };
      const Row rows[] = {
          {"B", "balanced", Vector6d::Constant(kBalanced)},
          {"C", "moment stiffness x0.01", MomentRatio(kMomentRatioC)},
          {"D", "moment stiffness x0.0001", MomentRatio(kMomentRatioD)},
          {"E", "JR3 67M25A as printed", TransducerPreset("jr3")},
          {"F", "ATI Mini40", TransducerPreset("ati-mini40")},
      };
      for (const Row& r : rows) {
        for (bool release : {true, false}) {
          panels.push_back(Eq10Panel(2, r.row, rat, release, r.s_t, 0.0, r.condition));
        }
      }
    } else {
      const std::pair<const char*, double> rows[] = {
          {"B", kBaseHigh}, {"C", kBaseModerate}, {"D", kBaseLow}};
      for (const auto& [row, k] : rows) {
        for (bool release : {true, false}) {
          panels.push_back(Eq10Panel(3, row, rat, release, Vector6d::Constant(kBalanced), k,
                                     std::string(row) == "B"   ? "high base stiffness"
                                     : std::string(row) == "C" ? "moderate base stiffness"
                                                               : "low base stiffness"));
        }
      }
      Model over(Configure(rat, false, Vector6d::Constant(kBalanced), 0.0));
      PaperPanel e;
      e.figure = 3;
      e.row = "E";
      e.column = kOverConstrained;
      e.method = "femur removed";
      e.condition = "tibia held only by the transducer, pulled directly by the muscle";
      e.wrench = FemurRemovedWrench(over, over.nominal_posture(), "GP");
      panels.push_back(e);
    }
  } else if (figure == 4) {
    Model rat6 = LoadRat(urdf_dir, "rat_hindlimb_6dof.urdf");
    rat6 = Model(WithJointStiffness(rat6.description(), "knee_ry", kKneeAbduction));
    panels.push_back(Eq10Panel(4, "A", rat6, false, Vector6d::Constant(kBalanced), 0.0,
                               "knee ball joint, balanced transducer"));
    panels.push_back(Eq10Panel(4, "B", rat6, false, MomentRatio(kMomentRatioD), 0.0,
                               "knee ball joint, unbalanced transducer"));
    panels.push_back(Eq10Panel(4, "C", rat6, false, Vector6d::Constant(kBalanced), kBaseModerate,
                               "knee ball joint, moderate base stiffness"));
  } else {
    throw Error("the paper has wrench figures 2, 3 and 4; there is no figure " +
                std::to_string(figure));
  }
  return panels;
}

}  // namespace isowrench
