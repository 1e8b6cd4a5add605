// OpenSim import against an independent evaluation of OpenSim's semantics written out here
// (shared/OPENSIM.md): X_G_child = X_G_parentbody X_parentbody_P X_PC(q) X_childbody_C^-1,
// body-fixed XYZ offset orientations, CustomJoint rotations as a body-fixed sequence and
// translations in P (not rotated), SimmSplines whose knots are sampled from cubics (so the
// spline is the cubic inside the knots and its end tangent outside), FreeJoint translations in
// the parent frame. Fixture: tests/opensim/data/hindlimb.osim.

#include "isowrench/opensim.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"

namespace isowrench {
namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

const std::string kFixture = std::string(ISOWRENCH_TEST_OSIM_DIR) + "/hindlimb.osim";

// Positions: sums of a few products of numbers below 0.1 m: rounding ~1e-17; spec 1e-9 m.
constexpr double kPosition = 1e-12;
// Central differences with h = 1e-6: truncation h^2 |f'''| ~ 1e-13, round-off eps L / h ~ 1e-11.
constexpr double kStep = 1e-6;
constexpr double kMomentArm = 1e-9;  // m (the bar)
constexpr double kJacobian = 1e-8;   // the bar

// ---- the independent OpenSim evaluation ------------------------------------------------------

Matrix3d Rx(double a) {
  Matrix3d R;
  R << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return R;
}
Matrix3d Ry(double a) {
  Matrix3d R;
  R << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return R;
}
Matrix3d Rz(double a) {
  Matrix3d R;
  R << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return R;
}
Isometry3d Pose(const Matrix3d& R, const Vector3d& p) {
  Isometry3d X = Isometry3d::Identity();
  X.linear() = R;
  X.translation() = p;
  return X;
}
// An offset frame: translation, then body-fixed X-Y-Z orientation.
Isometry3d Frame(const Vector3d& t, const Vector3d& xyz) {
  return Pose(Rx(xyz.x()) * Ry(xyz.y()) * Rz(xyz.z()), t);
}

// The cubics the fixture's SimmSpline knots were sampled from, and OpenSim's rule outside.
struct Cubic {
  double c0, c1, c2, c3;
  double f(double q) const { return c0 + q * (c1 + q * (c2 + q * c3)); }
  double df(double q) const { return c1 + q * (2 * c2 + 3 * c3 * q); }
};
constexpr double kLo = -2.0944, kHi = 0.17453;
double Spline(const Cubic& c, double q) {
  if (q < kLo) return c.f(kLo) + (q - kLo) * c.df(kLo);
  if (q > kHi) return c.f(kHi) + (q - kHi) * c.df(kHi);
  return c.f(q);
}
const Cubic kKneeTx{0.001, 0.002, -0.0015, 0.0004};
const Cubic kKneeTy{-0.0005, 0.001, 0.003, -0.0002};
const Cubic kKneeAdd{0.0, 0.02, 0.05, 0.01};

struct Posture {
  double hip_flexion = 0.2, hip_adduction = 0.0, hip_rotation = 0.1, knee = -0.5, ankle = 0.1;
};

// ground_pelvis FreeJoint at its defaults: translation in the parent frame, rotation XYZ.
Isometry3d GroundPelvis() {
  return Frame({0.01, 0.02, 0.03}, {0, 0, 0.1}) *
         Pose(Rx(0.1) * Ry(-0.2) * Rz(0.3), {0.05, 0.1, -0.02});
}
Isometry3d Hip(const Posture& p) {
  return Frame({-0.01, -0.005, 0.008}, {0.1, 0, 0.2}) *
         Pose(Rz(p.hip_flexion) * Rx(p.hip_adduction) * Ry(p.hip_rotation), Vector3d::Zero()) *
         Frame({0.001, 0.002, 0}, {0, 0.05, 0}).inverse();
}
Isometry3d Knee(const Posture& p) {
  const double k = p.knee;
  // translation2's axis is written (0 2 0): OpenSim normalises it.
  const Vector3d t(Spline(kKneeTx, k), Spline(kKneeTy, k), 0.5 * (0.002 * k + 0.001));
  return Frame({0, -0.035, 0}, {0, 0, 0}) * Pose(Rz(k) * Rx(Spline(kKneeAdd, k)) * Ry(0.05), t);
}
Isometry3d Ankle(const Posture& p) {
  return Frame({0, -0.04, 0}, {0, 0, -0.3}) * Pose(Rz(p.ankle), Vector3d::Zero()) *
         Frame({0.002, 0, 0}, {0.1, 0, 0}).inverse();
}

struct World {
  Isometry3d pelvis, femur, tibia, foot;
};
World Bodies(const Posture& p) {
  World w;
  w.pelvis = GroundPelvis();
  w.femur = w.pelvis * Hip(p);
  w.tibia = w.femur * Knee(p);
  w.foot = w.tibia * Ankle(p);
  return w;
}
const Vector3d kEndpointOnFoot(0.01, -0.005, 0.0);

double Length(const std::vector<Vector3d>& points) {
  double L = 0;
  for (size_t i = 1; i < points.size(); ++i) L += (points[i] - points[i - 1]).norm();
  return L;
}
double GmLength(const Posture& p) {
  World w = Bodies(p);
  return Length({w.pelvis * Vector3d(0.01, 0.005, 0.002), w.femur * Vector3d(0.003, -0.01, 0.001)});
}
double VasLength(const Posture& p) {
  World w = Bodies(p);
  return Length(
      {w.femur * Vector3d(0.002, -0.02, 0.003), w.tibia * Vector3d(0.004, -0.005, 0.001)});
}
double SolLength(const Posture& p) {
  World w = Bodies(p);
  return Length({w.tibia * Vector3d(-0.002, -0.01, 0), w.foot * Vector3d(-0.006, 0.001, 0.001)});
}

// RF: pelvis -> a MovingPathPoint on the tibia whose x is a SimmSpline of the knee (knots
// sampled from the cubic below, so the spline is that cubic on the knots' span), y a linear
// function of the knee, z a constant. OpenSim clamps the knee to its range [kLo, kHi] (here the
// knots' span) before evaluating them (MovingPathPoint::getLocation).
const Cubic kRfX{0.004, 0.001, -0.0005, 0.0001};
double RfLength(const Posture& p) {
  World w = Bodies(p);
  const double k = std::clamp(p.knee, kLo, kHi);
  const Vector3d moving(kRfX.f(k), 0.0005 * k + 0.001, 0.001);
  return Length({w.pelvis * Vector3d(0.012, 0.001, 0.002), w.tibia * moving});
}
// GAS: femur -> a ConditionalPathPoint on the tibia, in the path while the knee is within
// [-2, -0.3] widened by OpenSim's 1e-5 (ConditionalPathPoint::isActive) -> foot.
bool GasMiddleActive(const Posture& p) { return p.knee >= -2.0 - 1e-5 && p.knee <= -0.3 + 1e-5; }
double GasLength(const Posture& p) {
  World w = Bodies(p);
  std::vector<Vector3d> points = {w.femur * Vector3d(-0.002, -0.03, 0.001)};
  if (GasMiddleActive(p)) points.push_back(w.tibia * Vector3d(-0.003, -0.004, 0));
  points.push_back(w.foot * Vector3d(-0.005, 0.002, 0));
  return Length(points);
}

double& Coordinate(Posture& p, const std::string& name) {
  if (name == "hip_flexion") return p.hip_flexion;
  if (name == "hip_adduction") return p.hip_adduction;
  if (name == "hip_rotation") return p.hip_rotation;
  if (name == "knee_angle") return p.knee;
  if (name == "ankle_angle") return p.ankle;
  ADD_FAILURE() << "unknown coordinate " << name;
  static double dummy;
  return dummy;
}

// Postures over the coordinate ranges, the knee also exactly at and beyond its end knots.
std::vector<Posture> Postures() {
  std::vector<Posture> out;
  const double knees[] = {-2.2, kLo, -1.0, -0.3, kHi, 0.25};
  const double hips[][3] = {{0.2, 0.0, 0.1}, {-0.9, 0.4, -0.3}, {0.8, -0.45, 0.45}};
  for (double k : knees) {
    for (const auto& h : hips) {
      Posture p;
      p.hip_flexion = h[0];
      p.hip_adduction = h[1];
      p.hip_rotation = h[2];
      p.knee = k;
      p.ankle = -0.7 + 0.3 * (k + 2.2);
      out.push_back(p);
    }
  }
  return out;
}

// ---- the imported description, evaluated as URDF semantics with couplings -------------------

// child pose = parent pose * origin * motion(axis, coupling(q_coordinate)); no engine needed.
std::map<std::string, Isometry3d> LinkPoses(const LimbDescription& d, const Posture& posture) {
  Posture p = posture;
  std::map<std::string, Isometry3d> X;
  X[d.root_link] = Isometry3d::Identity();
  for (const JointSpec& j : d.joints) {
    Isometry3d motion = Isometry3d::Identity();
    if (j.type != JointType::kFixed) {
      const double value = j.coupling.Value(Coordinate(p, j.coordinate));
      if (j.type == JointType::kRevolute) {
        motion.linear() = Eigen::AngleAxisd(value, j.axis).toRotationMatrix();
      } else {
        motion.translation() = value * j.axis;
      }
    }
    X[j.child_link] = X.at(j.parent_link) * j.origin * motion;
  }
  return X;
}

// The URDF semantics of moving and conditional points (docs/urdf-extensions.md), evaluated on
// the description: component = f(clamp(q, coordinate range)); active within the range +- 1e-5.
double ImportedLength(const LimbDescription& d, const std::string& muscle, const Posture& p) {
  auto X = LinkPoses(d, p);
  Posture posture = p;
  for (const MuscleSpec& m : d.muscles) {
    if (m.name != muscle) continue;
    std::vector<Vector3d> points;
    for (const PathPoint& pt : m.path) {
      if (!pt.active_coordinate.empty()) {
        const double q = Coordinate(posture, pt.active_coordinate);
        if (q < pt.active_lower - 1e-5 || q > pt.active_upper + 1e-5) continue;
      }
      Vector3d position = pt.position;
      for (const MovingComponent& c : pt.moving) {
        const CoordinateSpec& spec = FindCoordinate(d, c.coordinate);
        const double q = std::clamp(Coordinate(posture, c.coordinate), spec.lower, spec.upper);
        position[c.axis] = c.function.Value(q);
      }
      points.push_back(X.at(pt.link) * position);
    }
    return Length(points);
  }
  ADD_FAILURE() << "no muscle " << muscle;
  return 0;
}

OpenSimImport Import(const std::string& clamp, const std::string& endpoint,
                     std::vector<std::string> unlock = {}) {
  OpenSimImportOptions options;
  options.clamp_body = clamp;
  options.endpoint_body = endpoint;
  options.endpoint_point = kEndpointOnFoot;
  options.unlock = std::move(unlock);
  return ImportOpenSimFile(kFixture, options);
}

// ---- structure -------------------------------------------------------------------------------

TEST(OpenSimImport, CoordinatesCouplingsAndLockedFlags) {
  const OpenSimImport import = Import("pelvis", "foot");
  const LimbDescription& d = import.description;
  std::vector<std::string> names;
  for (const CoordinateSpec& c : d.coordinates) names.push_back(c.name);
  EXPECT_THAT(names, ::testing::ElementsAre("hip_flexion", "hip_adduction", "hip_rotation",
                                            "knee_angle", "ankle_angle"));
  for (const CoordinateSpec& c : d.coordinates) {
    EXPECT_EQ(c.locked, c.name == "hip_rotation") << c.name;
    EXPECT_EQ(c.joint, c.name) << "every coordinate here is carried by a joint of its name";
  }
  EXPECT_NEAR(FindCoordinate(d, "knee_angle").lower, -2.0944, 0);
  EXPECT_EQ(FindCoordinate(d, "knee_angle").default_value, -0.5);
  std::map<std::string, const JointSpec*> joints;
  for (const JointSpec& j : d.joints) joints[j.name] = &j;
  ASSERT_TRUE(joints.count("knee_translation1"));
  EXPECT_EQ(joints["knee_translation1"]->coordinate, "knee_angle");
  EXPECT_EQ(joints["knee_translation1"]->coupling.kind(), FunctionKind::kSimmSpline);
  // MultiplierFunction(0.5, LinearFunction 0.002 q + 0.001) is linear: a mimic.
  ASSERT_TRUE(joints.count("knee_translation3"));
  EXPECT_TRUE(joints["knee_translation3"]->coupling.is_linear());
  EXPECT_DOUBLE_EQ(joints["knee_translation3"]->coupling.slope(), 0.001);
  EXPECT_DOUBLE_EQ(joints["knee_translation3"]->coupling.intercept(), 0.0005);
  // The constant rotation3 of the knee and the constant-zero hip translations make no joints.
  EXPECT_FALSE(joints.count("knee_rotation3"));
  EXPECT_FALSE(joints.count("hip_translation1"));
  // --unlock frees the locked coordinate.
  EXPECT_FALSE(
      FindCoordinate(Import("pelvis", "foot", {"hip_rotation"}).description, "hip_rotation")
          .locked);
}

TEST(OpenSimImport, MusclesWrapsAndSkippedMusclesAreReported) {
  const OpenSimImport import = Import("pelvis", "foot");
  std::vector<std::string> muscles;
  for (const MuscleSpec& m : import.description.muscles) muscles.push_back(m.name);
  EXPECT_THAT(muscles, ::testing::ElementsAre("GM", "VAS", "GAS", "RF", "SOL"));
  EXPECT_EQ(import.description.muscles[1].max_force, 3.0);
  auto warned = [&](const std::string& a, const std::string& b) {
    for (const std::string& w : import.warnings) {
      if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_FALSE(warned("'VAS'", "")) << "its wrap is imported";
  // VAS's PathWrap over the femur's WrapCylinder (OpenSim's defaults for what the file omits:
  // quadrant all, active, range -1 -1, method hybrid).
  ASSERT_EQ(import.description.muscles[1].wraps.size(), 1u);
  EXPECT_EQ(import.description.muscles[1].wraps[0].object, "knee_cyl");
  EXPECT_EQ(import.description.muscles[1].wraps[0].range_first, -1);
  EXPECT_EQ(import.description.muscles[1].wraps[0].range_last, -1);
  EXPECT_EQ(import.description.muscles[1].wraps[0].method, WrapMethod::kHybrid);
  ASSERT_EQ(import.description.wrap_objects.size(), 1u);
  const WrapObjectSpec& cyl = import.description.wrap_objects[0];
  EXPECT_EQ(cyl.link, "femur");
  EXPECT_EQ(cyl.shape, WrapShape::kCylinder);
  EXPECT_EQ(cyl.radius, 0.003);
  EXPECT_EQ(cyl.length, 0.01);
  EXPECT_EQ(cyl.quadrant.sign, 0);
  EXPECT_TRUE(cyl.active);
  EXPECT_TRUE(warned("'PAT'", "body 'patella', which is off the imported chain"));
  EXPECT_FALSE(warned("'GAS'", "")) << "the conditional point is imported";
  EXPECT_FALSE(warned("'RF'", "")) << "the moving point is imported";
  const std::string report = FormatOpenSimReport(import);
  EXPECT_THAT(report,
              AllOf(HasSubstr("marker  dropped"), HasSubstr("hip_rotation"), HasSubstr("locked"),
                    HasSubstr("PinJoint"), HasSubstr("imported, 1 moving point"),
                    HasSubstr("imported, wraps over knee_cyl"),
                    HasSubstr("imported, 1 conditional point")));
  // RF's moving point: x and y follow the knee (the constant z is folded into the position);
  // GAS's middle point is active on the knee's [-2, -0.3].
  const PathPoint& rf = import.description.muscles[3].path[1];
  ASSERT_EQ(rf.moving.size(), 2u);
  EXPECT_EQ(rf.moving[0].axis, 0);
  EXPECT_EQ(rf.moving[0].coordinate, "knee_angle");
  EXPECT_EQ(rf.moving[0].function.kind(), FunctionKind::kSimmSpline);
  EXPECT_EQ(rf.moving[1].axis, 1);
  EXPECT_EQ(rf.position.z(), 0.001);
  const PathPoint& gas = import.description.muscles[2].path[1];
  EXPECT_EQ(gas.active_coordinate, "knee_angle");
  EXPECT_EQ(gas.active_lower, -2.0);
  EXPECT_EQ(gas.active_upper, -0.3);
}

// ---- kinematics against the independent evaluation -------------------------------------------

TEST(OpenSimImport, EndpointAndMuscleLengthsMatchOpenSimTransforms) {
  const LimbDescription d = Import("pelvis", "foot").description;
  for (const Posture& p : Postures()) {
    const World w = Bodies(p);
    auto X = LinkPoses(d, p);
    EXPECT_LT((X.at("foot") * kEndpointOnFoot - w.foot * kEndpointOnFoot).norm(), kPosition)
        << "knee " << p.knee;
    EXPECT_LT((X.at("foot").linear() - w.foot.linear()).norm(), kPosition);
    EXPECT_NEAR(ImportedLength(d, "GM", p), GmLength(p), kPosition);
    EXPECT_NEAR(ImportedLength(d, "VAS", p), VasLength(p), kPosition);
    EXPECT_NEAR(ImportedLength(d, "SOL", p), SolLength(p), kPosition);
    EXPECT_NEAR(ImportedLength(d, "RF", p), RfLength(p), kPosition) << "knee " << p.knee;
    EXPECT_NEAR(ImportedLength(d, "GAS", p), GasLength(p), kPosition) << "knee " << p.knee;
  }
}

TEST(OpenSimImport, ClampBakesTheJointsAboveItAtTheirDefaults) {
  // Clamp the femur: ground_pelvis and the hip are fixed at the defaults, GM's pelvis point is
  // on the ground, and the world positions are still those of the .osim.
  const OpenSimImport import = Import("femur", "foot");
  const LimbDescription& d = import.description;
  EXPECT_EQ(d.coordinates.size(), 2u);  // knee_angle, ankle_angle
  const MuscleSpec& gm = d.muscles.front();
  ASSERT_EQ(gm.name, "GM");
  EXPECT_EQ(gm.path[0].link, "ground");
  EXPECT_LT((gm.path[0].position - GroundPelvis() * Vector3d(0.01, 0.005, 0.002)).norm(),
            kPosition);
  for (const Posture& p : Postures()) {
    Posture at_default = p;
    at_default.hip_flexion = 0.2;
    at_default.hip_adduction = 0.0;
    at_default.hip_rotation = 0.1;
    auto X = LinkPoses(d, at_default);
    EXPECT_LT((X.at("foot") * kEndpointOnFoot - Bodies(at_default).foot * kEndpointOnFoot).norm(),
              kPosition);
  }
}

// The engine's answer (Model + kinematics) for the imported model, with the Jacobian and the
// moment arms against central differences of the independent evaluation.
void CheckEngine(const LimbDescription& d, const std::vector<Posture>& postures,
                 const std::vector<std::string>& muscles,
                 const std::map<std::string, std::function<double(const Posture&)>>& lengths,
                 bool at_foot) {
  Model model(d);
  ASSERT_EQ(model.dof_count(), static_cast<int>(d.coordinates.size()))
      << "the engine's columns must be the coordinates";
  Data ws(model);
  const std::vector<std::string>& columns = model.joint_names();
  auto endpoint = [&](const Posture& p) {
    World w = Bodies(p);
    return at_foot ? Vector3d(w.foot * kEndpointOnFoot) : Vector3d(w.femur * kEndpointOnFoot);
  };
  auto rotation = [&](const Posture& p) {
    World w = Bodies(p);
    return at_foot ? Matrix3d(w.foot.linear()) : Matrix3d(w.femur.linear());
  };
  for (const Posture& p0 : postures) {
    Posture p = p0;
    Eigen::VectorXd q(columns.size());
    for (size_t i = 0; i < columns.size(); ++i) q[i] = Coordinate(p, columns[i]);
    EXPECT_LT((EndpointPose(model, ws, q).translation() - endpoint(p)).norm(), 1e-9);
    const Matrix6Xd J = EndpointJacobianWorld(model, ws, q);
    for (size_t i = 0; i < columns.size(); ++i) {
      Posture plus = p, minus = p;
      Coordinate(plus, columns[i]) += kStep;
      Coordinate(minus, columns[i]) -= kStep;
      const Vector3d v = (endpoint(plus) - endpoint(minus)) / (2 * kStep);
      const Matrix3d W = (rotation(plus) - rotation(minus)) / (2 * kStep) * rotation(p).transpose();
      const Vector3d w(W(2, 1), W(0, 2), W(1, 0));
      EXPECT_LT((J.col(i).head<3>() - v).norm(), kJacobian) << columns[i] << " knee " << p.knee;
      EXPECT_LT((J.col(i).tail<3>() - w).norm(), kJacobian) << columns[i];
      for (const std::string& name : muscles) {
        const auto& L = lengths.at(name);
        const double r = -(L(plus) - L(minus)) / (2 * kStep);  // OpenSim: r = -dL/dq
        const MuscleTorque t = ComputeMuscleTorque(model, ws, q, model.MuscleIndex(name));
        EXPECT_NEAR(-t.dL_dq[i], r, kMomentArm) << name << " about " << columns[i];
      }
    }
    for (const std::string& name : muscles) {
      const MuscleTorque t = ComputeMuscleTorque(model, ws, q, model.MuscleIndex(name));
      EXPECT_NEAR(t.length, lengths.at(name)(p), 1e-9) << name;
    }
  }
}

TEST(OpenSimImport, EngineMatchesOnTheUncoupledHip) {
  // pelvis -> femur: three revolute coordinates, offsets with orientations, a locked one.
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "femur";
  options.endpoint_point = kEndpointOnFoot;
  const LimbDescription d = ImportOpenSimFile(kFixture, options).description;
  std::vector<Posture> postures;
  for (const Posture& p : Postures()) {
    if (p.knee == kLo) postures.push_back(p);
  }
  CheckEngine(d, postures, {"GM"}, {{"GM", GmLength}}, false);
}

TEST(OpenSimImport, EngineMatchesOnTheSplineCoupledKnee) {
  const LimbDescription d = Import("pelvis", "foot").description;
  std::vector<Posture> postures;
  for (const Posture& p : Postures()) {
    // Central differences straddling an end knot see the jump of f'' there: keep away.
    if (std::abs(p.knee - kLo) > 1e-3 && std::abs(p.knee - kHi) > 1e-3) postures.push_back(p);
  }
  // RF's moving point is clamped beyond the knee's range (knee -2.2 and 0.25): its length is
  // constant in the knee there and its moment arm is that of the rigid point. GAS's middle
  // point is in the path at knee -1 and -0.3 only.
  CheckEngine(d, postures, {"GM", "VAS", "SOL", "RF", "GAS"},
              {{"GM", GmLength},
               {"VAS", VasLength},
               {"SOL", SolLength},
               {"RF", RfLength},
               {"GAS", GasLength}},
              true);
}

TEST(OpenSimImport, Version30000LayoutGivesTheSameHip) {
  // OpenSim 3.x: the joint inside its child body, location_in_parent/orientation_in_parent,
  // functions in <function> wrappers, <body> on path points. The pelvis is welded at the
  // ground_offset pose of hindlimb.osim (no FreeJoint), so X_G_pelvis = that frame.
  OpenSimImportOptions options;
  options.clamp_body = "ground";
  options.endpoint_body = "femur";
  const OpenSimImport import =
      ImportOpenSimFile(std::string(ISOWRENCH_TEST_OSIM_DIR) + "/hip_v30000.osim", options);
  EXPECT_EQ(import.version, 30000);
  const LimbDescription& d = import.description;
  ASSERT_EQ(d.coordinates.size(), 3u);
  EXPECT_TRUE(FindCoordinate(d, "hip_rotation").locked);
  EXPECT_EQ(d.joints.front().name, "pelvis_joint");  // the unnamed WeldJoint
  const Isometry3d X_G_pelvis = Frame({0.01, 0.02, 0.03}, {0, 0, 0.1});
  for (const Posture& p : Postures()) {
    auto X = LinkPoses(d, p);
    const Isometry3d femur = X_G_pelvis * Hip(p);
    EXPECT_LT((X.at("femur").translation() - femur.translation()).norm(), kPosition);
    EXPECT_LT((X.at("femur").linear() - femur.linear()).norm(), kPosition);
    const double gm =
        Length({X_G_pelvis * Vector3d(0.01, 0.005, 0.002), femur * Vector3d(0.003, -0.01, 0.001)});
    EXPECT_NEAR(ImportedLength(d, "GM", p), gm, kPosition);
  }
}

TEST(OpenSimImport, CoordinateCouplerConstraintDrivesTheDependentAxes) {
  // ankle_angle = 2 (0.5 knee_angle + 0.1) = knee_angle + 0.2: the ankle's pin follows the
  // knee, and ankle_angle is no longer a column.
  std::ifstream in(kFixture);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const std::string constraint =
      "<ConstraintSet><objects><CoordinateCouplerConstraint name=\"ankle_follows_knee\">"
      "<isEnforced>true</isEnforced><coupled_coordinates_function><LinearFunction>"
      "<coefficients>0.5 0.1</coefficients></LinearFunction></coupled_coordinates_function>"
      "<independent_coordinate_names>knee_angle</independent_coordinate_names>"
      "<dependent_coordinate_name>ankle_angle</dependent_coordinate_name>"
      "<scale_factor>2</scale_factor></CoordinateCouplerConstraint></objects></ConstraintSet>\n";
  text.insert(text.find("<ForceSet"), constraint);
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  const LimbDescription d = ImportOpenSimString(text, "coupled.osim", options).description;
  std::vector<std::string> names;
  for (const CoordinateSpec& c : d.coordinates) names.push_back(c.name);
  EXPECT_THAT(names,
              ::testing::ElementsAre("hip_flexion", "hip_adduction", "hip_rotation", "knee_angle"));
  for (Posture p : Postures()) {
    p.ankle = 12.3;  // ignored: the ankle follows the knee
    auto X = LinkPoses(d, p);
    Posture follows = p;
    follows.ankle = p.knee + 0.2;
    EXPECT_LT((X.at("foot") * kEndpointOnFoot - Bodies(follows).foot * kEndpointOnFoot).norm(),
              kPosition);
  }
}

TEST(OpenSimImport, WrittenUrdfReadsBackToTheSameKinematics) {
  const LimbDescription d = Import("pelvis", "foot").description;
  const LimbDescription back = ReadUrdfString(WriteUrdfString(d), "imported.urdf");
  EXPECT_EQ(back.coordinates.size(), d.coordinates.size());
  EXPECT_TRUE(FindCoordinate(back, "hip_rotation").locked);
  EXPECT_EQ(back.muscles.size(), d.muscles.size());
  for (const Posture& p : Postures()) {
    auto X = LinkPoses(back, p);
    EXPECT_LT((X.at("foot") * kEndpointOnFoot - Bodies(p).foot * kEndpointOnFoot).norm(),
              kPosition);
  }
}

// ---- bad input -------------------------------------------------------------------------------

std::string FixtureText() {
  std::ifstream in(kFixture);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The fixture with `from` replaced by `to` (first occurrence), and the 1-based line of it.
std::pair<std::string, int> Edited(const std::string& from, const std::string& to) {
  std::string text = FixtureText();
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
  text.replace(at, from.size(), to);
  return {text, line};
}

void ExpectError(const std::string& text, const std::string& where, const std::string& what,
                 const std::string& clamp = "pelvis", const std::string& endpoint = "foot") {
  OpenSimImportOptions options;
  options.clamp_body = clamp;
  options.endpoint_body = endpoint;
  EXPECT_THAT([&] { ImportOpenSimString(text, "hindlimb.osim", options); },
              ThrowsMessage<Error>(AllOf(HasSubstr(where), HasSubstr(what))));
}

TEST(OpenSimImportErrors, NameFileLineJointAxisAndRule) {
  {
    auto [text, line] = Edited("</BodySet>", "");
    ExpectError(text, "hindlimb.osim:", "malformed XML");
  }
  {
    std::string text = Edited("<PinJoint name=\"ankle\">", "<EllipsoidJoint name=\"ankle\">").first;
    const int line = Edited("<PinJoint name=\"ankle\">", "").second;
    const size_t close = text.find("</PinJoint>");
    text.replace(close, 11, "</EllipsoidJoint>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line) + ":",
                "joint 'ankle' has the type 'EllipsoidJoint', which is not supported");
  }
  {
    std::string text = FixtureText();
    const std::string from = "<SimmSpline name=\"function\">";
    const size_t at = text.find(
        from, text.find("<TransformAxis name=\"rotation2\">", text.find("name=\"knee\"")));
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
    text.replace(at, from.size(), "<GCVSpline name=\"function\">");
    text.replace(text.find("</SimmSpline>", at), 13, "</GCVSpline>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line) + ":",
                "joint 'knee' axis 'rotation2': function type 'GCVSpline' is not supported");
  }
  {
    auto [text, line] = Edited("<x> -2.0944 -1.7 -1.2 -0.6 0 0.17453</x>",
                               "<x> -2.0944 -1.7 -1.2 -1.3 0 0.17453</x>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line - 1) + ":",
                "SimmSpline knots must be strictly increasing: x[3] = -1.3 is below x[2] = -1.2");
  }
  {
    auto [text, line] = Edited("<x> -2.0944 -1.7 -1.2 -0.6 0 0.17453</x>",
                               "<x> -2.0944 -1.7 nan -0.6 0 0.17453</x>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line) + ":", "'nan' is not finite");
  }
  {
    const std::string hip_rotation3 =
        "<coordinates>hip_rotation</coordinates>\n              <axis>0 1 0</axis>";
    auto [text, line] = Edited(hip_rotation3,
                               "<coordinates>hip_rotation</coordinates>\n"
                               "              <axis>0 0 2</axis>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line - 1) + ":",
                "joint 'hip': axes 'rotation1' and 'rotation3' are collinear");
  }
  {
    auto [text, line] = Edited("<socket_child_frame>foot_offset</socket_child_frame>", "");
    ExpectError(text, "hindlimb.osim:", "joint 'ankle' has no <socket_child_frame>");
  }
  {
    auto [text, line] = Edited(
        "<socket_parent>/bodyset/tibia</socket_parent>\n              <translation>0 -0.04 "
        "0</translation>",
        "<socket_parent>/bodyset/shank</socket_parent>\n              <translation>0 -0.04 "
        "0</translation>");
    ExpectError(text, "hindlimb.osim:", "'/bodyset/shank' names no body of the model");
  }
  {
    auto [text, line] =
        Edited("<PinJoint name=\"ankle\">", "<PinJoint name=\"ankle\"><reverse>true</reverse>");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line) + ":", "joint 'ankle' is reversed");
  }
  {  // OpenSim 4 refuses a MovingPathPoint whose components follow different coordinates
    auto [text, line] =
        Edited("<socket_y_coordinate>/jointset/knee/knee_angle</socket_y_coordinate>", "");
    const int point_line = Edited("<MovingPathPoint name=\"RF-P2\">", "").second;
    ExpectError(text, "hindlimb.osim:" + std::to_string(point_line) + ":",
                "muscle 'RF' point 'RF-P2': its x, y and z locations depend on the coordinates "
                "'knee_angle', '', 'knee_angle'");
  }
  {  // found by the .osim fuzz campaign (2026-11-25): two muscles of one name were imported and
     // written into a URDF that the reader then refused (fuzz/corpus/osim/duplicate_muscle.osim)
    const int first = Edited("<Millard2012EquilibriumMuscle name=\"RF\">", "").second;
    auto [text, line] = Edited("<Millard2012EquilibriumMuscle name=\"SOL\">",
                               "<Millard2012EquilibriumMuscle name=\"RF\">");
    ExpectError(text, "hindlimb.osim:" + std::to_string(line) + ":",
                "muscle 'RF' is declared twice (first at line " + std::to_string(first) + ")");
  }
  const std::string text = FixtureText();
  ExpectError(text, "hindlimb.osim", "--clamp body 'patella' is not on the path from ground",
              "patella", "foot");
  ExpectError(text, "hindlimb.osim", "--endpoint body 'paw' does not exist", "pelvis", "paw");
  OpenSimImportOptions unlock;
  unlock.clamp_body = "pelvis";
  unlock.endpoint_body = "foot";
  unlock.unlock = {"hip_rot"};
  EXPECT_THAT(
      [&] { ImportOpenSimString(text, "hindlimb.osim", unlock); },
      ThrowsMessage<Error>(HasSubstr("--unlock names coordinate 'hip_rot', which does not exist")));
}

// ---- constant couplings (issue 25, item 1) -----------------------------------------------------

// The fixture with the knee's translation2 axis (a SimmSpline of knee_angle) replaced by `axis`,
// and the knee's range by `range`.
std::string KneeTranslation2(const std::string& axis,
                             const std::string& range = "-2.0944 0.17453") {
  std::string text = FixtureText();
  const size_t knee = text.find("<CustomJoint name=\"knee\">");
  const size_t begin = text.find("<TransformAxis name=\"translation2\">", knee);
  const size_t end = text.find("</TransformAxis>", begin) + std::string("</TransformAxis>").size();
  text.replace(begin, end - begin,
               "<TransformAxis name=\"translation2\">" + axis + "</TransformAxis>");
  const std::string old_range = "<range>-2.0944 0.17453</range>";
  text.replace(text.find(old_range, knee), old_range.size(), "<range>" + range + "</range>");
  return text;
}

// An axis whose function is constant over its coordinate's range becomes part of the fixed
// transform at that constant, exactly as an axis of no coordinate with a Constant does (the
// reference), and the report says so; a function constant over the range only where the range
// ends inside its flat part, so a wider range keeps the joint.
TEST(OpenSimImport, AxesConstantOverTheRangeAreFixedAtTheirConstant) {
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  options.endpoint_point = kEndpointOnFoot;
  auto import = [&](const std::string& text) {
    return ImportOpenSimString(text, "edited.osim", options);
  };
  const std::string axis_y = "<axis>0 2 0</axis>";
  const std::string of_knee = "<coordinates>knee_angle</coordinates>" + axis_y;
  const std::string zeros = of_knee +
                            "<SimmSpline name=\"function\"><x>-2.0944 -1.7 -1.2 -0.6 0 0.17453</x>"
                            "<y>0 0 0 0 0 0</y></SimmSpline>";
  // 2 mm between -2.2 and 0.3 rad (the knee's range, -2.0944 .. 0.17453, inside), rising beyond.
  const std::string flat = of_knee +
                           "<PiecewiseLinearFunction name=\"function\"><x>-3 -2.2 0.3 1</x>"
                           "<y>0.01 0.002 0.002 0.004</y></PiecewiseLinearFunction>";
  auto constant = [&](const std::string& value) {
    return "<coordinates></coordinates>" + axis_y + "<Constant name=\"function\"><value>" + value +
           "</value></Constant>";
  };
  struct Case {
    std::string axis, reference;
  };
  for (const Case& c : {Case{zeros, constant("0")}, Case{flat, constant("0.002")}}) {
    const OpenSimImport imported = import(KneeTranslation2(c.axis));
    const OpenSimImport reference = import(KneeTranslation2(c.reference));
    const LimbDescription& d = imported.description;
    std::vector<std::string> joints, reference_joints;
    for (const JointSpec& j : d.joints) joints.push_back(j.name);
    for (const JointSpec& j : reference.description.joints) reference_joints.push_back(j.name);
    EXPECT_EQ(joints, reference_joints);
    EXPECT_EQ(std::count(joints.begin(), joints.end(), "knee_translation2"), 0);
    for (const Posture& p : Postures()) {  // (knees beyond the range too: constant both)
      const auto X = LinkPoses(d, p);
      const auto X_ref = LinkPoses(reference.description, p);
      EXPECT_LT((X.at("foot").matrix() - X_ref.at("foot").matrix()).cwiseAbs().maxCoeff(), 1e-15);
    }
    const std::string value = c.axis == zeros ? "0 mm" : "2 mm";
    EXPECT_THAT(FormatOpenSimReport(imported),
                HasSubstr("knee_translation2 fixed at " + value + " (" +
                          (c.axis == zeros ? "simm_spline" : "piecewise_linear") +
                          " of knee_angle, constant over its range)"));
  }
  // The knee's range widened to -2.5: the function rises over the range; a coupled joint.
  const LimbDescription wide = import(KneeTranslation2(flat, "-2.5 0.17453")).description;
  const auto joint = std::find_if(wide.joints.begin(), wide.joints.end(),
                                  [](const JointSpec& j) { return j.name == "knee_translation2"; });
  ASSERT_NE(joint, wide.joints.end());
  EXPECT_EQ(joint->coordinate, "knee_angle");
  EXPECT_NEAR(joint->coupling.Value(-2.4), 0.002 + 0.008 * 0.2 / 0.8, 1e-15);
}

}  // namespace
}  // namespace isowrench
