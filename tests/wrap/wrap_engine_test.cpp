// Wraps in the engine (issue 27 stage 2): the engine's length and dL/dq of a wrapping muscle
// against ComputeWrappedPath built independently from PointPosition / PointJacobian; exact-mode
// moment arms against central differences of the engine's own length through the whole Model;
// OpenSim-mode moment arms where OpenSim's cylinder path is a shortest path; the batch against
// the single evaluation; the wrap mode as a model setting (ApplyOverrides).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/frontend.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {
namespace {

LimbDescription WrapsFixture(WrapMode mode) {
  std::ifstream in(std::string(ISOWRENCH_TEST_OSIM_DIR) + "/wraps.osim");
  std::stringstream s;
  s << in.rdbuf();
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  LimbDescription d = ImportOpenSimString(s.str(), "wraps.osim", options).description;
  d.wrap_mode = mode;
  return d;
}

// A posture uniformly inside every coordinate's range (finite ranges; +-1 rad / 1 cm otherwise).
Eigen::VectorXd RandomPosture(const Model& model, std::mt19937& rng) {
  Eigen::VectorXd q(model.dof_count());
  for (int c = 0; c < model.dof_count(); ++c) {
    const CoordinateSpec& s = model.description().coordinates[c];
    const double span = s.type == JointType::kPrismatic ? 0.01 : 1.0;
    const double lo = std::isfinite(s.lower) ? s.lower : -span;
    const double hi = std::isfinite(s.upper) ? s.upper : span;
    q[c] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  return q;
}

int Column(const Model& model, const std::string& coordinate) {
  const auto& names = model.joint_names();
  return static_cast<int>(std::find(names.begin(), names.end(), coordinate) - names.begin());
}

// The muscle's wrapped path and dL/dq from the public kinematics functions only: each point's
// world position (PointPosition), its activity from its coordinate, each wrap object's frame
// from three points of its link, and dL/dq = sum of pull . PointJacobian over the path points
// and over the tangent points as points of the wrap object's link (wrap.hpp "Moment arms").
struct Independent {
  WrappedPath path;
  Eigen::VectorXd dL;
};

Independent IndependentPath(const Model& model, Data& data, const Eigen::VectorXd& q, int muscle) {
  const MuscleSpec& m = model.muscle(muscle);
  const auto& objects = model.description().wrap_objects;
  WrapPathInput in;
  for (const PathPoint& p : m.path) {
    EXPECT_TRUE(p.moving.empty()) << m.name;
    in.points.push_back(PointPosition(model, data, q, p.link, p.position));
    bool active = true;
    if (!p.active_coordinate.empty()) {
      const double x = q[Column(model, p.active_coordinate)];
      active = x >= p.active_lower - 1e-5 && x <= p.active_upper + 1e-5;
    }
    in.active.push_back(active ? 1 : 0);
  }
  std::vector<const WrapObjectSpec*> object_of;
  for (const PathWrapSpec& w : m.wraps) {
    const auto o = std::find_if(objects.begin(), objects.end(),
                                [&](const WrapObjectSpec& s) { return s.name == w.object; });
    object_of.push_back(&*o);
    WrapPathWrap pw;
    pw.surface = WrapSurface::From(*o);
    const Eigen::Isometry3d X = o->Pose();
    const Eigen::Vector3d origin = PointPosition(model, data, q, o->link, X.translation());
    pw.X_W_S.translation() = origin;
    for (int k = 0; k < 3; ++k) {
      pw.X_W_S.linear().col(k) =
          PointPosition(model, data, q, o->link, X * Eigen::Vector3d::Unit(k)) - origin;
    }
    const int n = static_cast<int>(m.path.size());
    pw.first = w.range_first < 1 ? 0 : w.range_first - 1;
    pw.last = w.range_last < 1 ? n - 1 : w.range_last - 1;
    pw.method = w.method;
    pw.active = o->active;
    pw.object = static_cast<int>(o - objects.begin());
    in.wraps.push_back(pw);
  }
  Independent out;
  ComputeWrappedPath(in, model.description().wrap_mode, out.path);
  out.dL = Eigen::VectorXd::Zero(model.dof_count());
  for (size_t i = 0; i < m.path.size(); ++i) {
    out.dL += (out.path.point_pull[i].transpose() *
               PointJacobian(model, data, q, m.path[i].link, m.path[i].position))
                  .transpose();
  }
  for (size_t j = 0; j < m.wraps.size(); ++j) {
    const WrappedPath::Wrap& w = out.path.wraps[j];
    if (!w.wrapped) continue;
    const WrapObjectSpec& o = *object_of[j];
    for (const auto& [r_S, pull] : {std::pair{w.r1_S, w.pull_r1}, std::pair{w.r2_S, w.pull_r2}}) {
      out.dL +=
          (pull.transpose() * PointJacobian(model, data, q, o.link, o.Pose() * r_S)).transpose();
    }
  }
  return out;
}

// Engine == ComputeWrappedPath on the same kinematics, both modes, every wrapping muscle of the
// fixture (cylinder on the clamp, cylinder, ellipsoid + torus + inactive sphere with a
// conditional point), and the muscles without wraps still straight.
TEST(WrapEngineTest, EngineLengthAndGradientEqualComputeWrappedPath) {
  // (second round: every object active, so that GAS's sphere takes part too)
  for (const auto& [mode, all_active] :
       {std::pair{WrapMode::kOpenSim, false}, std::pair{WrapMode::kExact, false},
        std::pair{WrapMode::kOpenSim, true}, std::pair{WrapMode::kExact, true}}) {
    LimbDescription d = WrapsFixture(mode);
    for (WrapObjectSpec& o : d.wrap_objects) o.active = o.active || all_active;
    const Model model(d);
    Data engine(model), reference(model);
    std::mt19937 rng(7);
    int wrapped = 0, compared = 0;
    for (int trial = 0; trial < 60; ++trial) {
      const Eigen::VectorXd q = RandomPosture(model, rng);
      for (int i = 0; i < model.muscle_count(); ++i) {
        const MuscleSpec& m = model.muscle(i);
        if (m.wraps.empty()) continue;
        ASSERT_TRUE(ComputeKinematics(model, engine, q, i, 1.0)) << m.name;
        const Independent ref = IndependentPath(model, reference, q, i);
        EXPECT_NEAR(engine.muscle_length(), ref.path.length, 1e-12) << m.name << " " << trial;
        for (int c = 0; c < model.dof_count(); ++c) {
          EXPECT_NEAR(engine.muscle_length_gradient()[c], ref.dL[c], 1e-12)
              << m.name << " column " << c << " trial " << trial;
        }
        // tau = -F dL/dq with the engine's force (activation 1: the constant model's max_force
        // or the force model's; only its sign and proportionality are checked here).
        for (const WrappedPath::Wrap& w : ref.path.wraps) wrapped += w.wrapped ? 1 : 0;
        ++compared;
      }
    }
    EXPECT_EQ(compared, 180);  // (3 wrapping muscles x 60 postures)
    EXPECT_GT(wrapped, 20) << WrapModeName(mode) << ": too few postures where a wrap engages";
  }
}

// The same on a model whose workspace is the large one (a muscle of 70 points: more than the
// small workspace's 64), the knee_wrap leg of tests/wrap/data.
TEST(WrapEngineTest, LargeWorkspaceEvaluatesWrapsToo) {
  LimbDescription d = ReadUrdfFile(std::string(ISOWRENCH_TEST_WRAP_DIR) + "/knee_wrap.urdf");
  MuscleSpec many;
  many.name = "MANY";
  many.max_force = 1.0;
  for (int k = 0; k < 70; ++k) {
    many.path.push_back({k % 2 ? "tibia" : "femur", Eigen::Vector3d(0.01 + 1e-4 * k, -0.004, 0)});
  }
  d.muscles.push_back(many);
  for (const WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    d.wrap_mode = mode;
    const Model model(d);
    Data engine(model), reference(model);
    int wrapped = 0;
    for (double knee = -2.4; knee <= 2.4; knee += 0.2) {
      Eigen::VectorXd q(2);
      q << 0.3, knee;
      ASSERT_TRUE(ComputeKinematics(model, engine, q, 0, 1.0));
      const Independent ref = IndependentPath(model, reference, q, 0);
      EXPECT_NEAR(engine.muscle_length(), ref.path.length, 1e-12) << knee;
      for (int c = 0; c < 2; ++c) {
        EXPECT_NEAR(engine.muscle_length_gradient()[c], ref.dL[c], 1e-12) << knee;
      }
      wrapped += ref.path.wraps[0].wrapped ? 1 : 0;
    }
    EXPECT_GT(wrapped, 3);
  }
}

// A chain of two revolute joints about z with a muscle from the femur to the tibia over a
// cylinder on the femur whose axis is z: every point and the cylinder's cross-section lie in
// the plane z = 0, where OpenSim's cylinder path is the shortest path.
LimbDescription PlanarCylinderLeg(const std::string& quadrant) {
  const std::string urdf = R"(<?xml version="1.0"?>
<robot name="leg" xmlns:isowrench="urn:isowrench:urdf:1">
  <link name="ground"/> <link name="femur"/> <link name="tibia"/>
  <joint name="hip" type="revolute"><parent link="ground"/><child link="femur"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="knee" type="revolute"><parent link="femur"/><child link="tibia"/>
    <origin xyz="0.04 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <isowrench:transducer link="tibia" xyz="0.04 0 0"/>
  <isowrench:wrap name="knee_cyl" link="femur" shape="cylinder" radius="0.005" length="0.05"
      translation="0.04 0 0" quadrant=")" +
                           quadrant + R"("/>
  <isowrench:muscle name="QUAD" max_force="2">
    <isowrench:point link="ground" xyz="0.002 0.008 0"/>
    <isowrench:point link="femur" xyz="0.02 0.007 0"/>
    <isowrench:point link="tibia" xyz="0.015 0.006 0"/>
    <isowrench:path_wrap object="knee_cyl" range="2 3"/>
  </isowrench:muscle>
  <isowrench:muscle name="STRAIGHT" max_force="1">
    <isowrench:point link="femur" xyz="0.02 0.007 0"/>
    <isowrench:point link="tibia" xyz="0.015 0.006 0"/>
  </isowrench:muscle>
</robot>
)";
  return ReadUrdfString(urdf, "planar_leg.urdf");
}

// d/dq of the engine's length by central differences (h = 1e-6 rad).
Eigen::VectorXd DifferencedGradient(const Model& model, Data& data, const Eigen::VectorXd& q,
                                    int muscle) {
  Eigen::VectorXd g(model.dof_count());
  const double h = 1e-6;
  for (int c = 0; c < model.dof_count(); ++c) {
    Eigen::VectorXd a = q, b = q;
    a[c] += h;
    b[c] -= h;
    EXPECT_TRUE(ComputeKinematics(model, data, a, muscle, 1.0));
    const double la = data.muscle_length();
    EXPECT_TRUE(ComputeKinematics(model, data, b, muscle, 1.0));
    g[c] = (la - data.muscle_length()) / (2 * h);
  }
  return g;
}

// Both modes: OpenSim's cylinder path is the shortest one here, and the exact one is always.
TEST(WrapEngineTest, OpenSimCylinderInOneCrossSectionGivesMinusDLdq) {
  for (const std::string quadrant : {"all", "+y", "exact"}) {
    LimbDescription d = PlanarCylinderLeg(quadrant == "exact" ? "all" : quadrant);
    if (quadrant == "exact") d.wrap_mode = WrapMode::kExact;
    const Model model(d);
    Data data(model);
    int wrapped = 0;
    for (double knee = -2.2; knee <= 2.2; knee += 0.1) {
      Eigen::VectorXd q(2);
      q << 0.3, knee;
      const Eigen::VectorXd fd = DifferencedGradient(model, data, q, 0);
      ASSERT_TRUE(ComputeKinematics(model, data, q, 0, 1.0));
      const WrappedPath path = MuscleWrappedPath(model, data, q, 0);
      ASSERT_TRUE(ComputeKinematics(model, data, q, 0, 1.0));
      wrapped += path.wraps[0].wrapped ? 1 : 0;
      for (int c = 0; c < 2; ++c) {
        EXPECT_NEAR(data.muscle_length_gradient()[c], fd[c], 1e-8)
            << quadrant << " knee " << knee << " column " << c;
      }
    }
    EXPECT_GT(wrapped, 10) << quadrant;
  }
}

TEST(WrapEngineTest, ExactModeMomentArmIsMinusDLdqThroughTheModel) {
  const Model model(WrapsFixture(WrapMode::kExact));
  Data data(model);
  std::mt19937 rng(11);
  std::map<std::string, int> compared;
  for (int trial = 0; trial < 60; ++trial) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    for (int i = 0; i < model.muscle_count(); ++i) {
      if (model.muscle(i).wraps.empty()) continue;
      const WrappedPath path = MuscleWrappedPath(model, data, q, i);
      bool engaged = false;
      for (const WrappedPath::Wrap& w : path.wraps) engaged = engaged || w.wrapped;
      // Only where a wrap engages and the exact solve succeeded, and where the length is smooth
      // around q (OpenSim's rules make it jump where a wrap or a segment choice switches): the
      // central differences with steps 1e-6 and 1e-4 rad agree (the engine's gradient is not
      // used to choose).
      if (!engaged || (path.status & (kWrapExactFallback | kWrapNotConverged))) continue;
      const Eigen::VectorXd fd = DifferencedGradient(model, data, q, i);
      bool smooth = true;
      for (int c = 0; c < model.dof_count() && smooth; ++c) {
        Eigen::VectorXd a = q;
        a[c] += 1e-4;
        ComputeKinematics(model, data, a, i, 1.0);
        const double la = data.muscle_length();
        a[c] -= 2e-4;
        ComputeKinematics(model, data, a, i, 1.0);
        smooth = std::abs((la - data.muscle_length()) / 2e-4 - fd[c]) < 1e-6;
      }
      if (!smooth) continue;
      ASSERT_TRUE(ComputeKinematics(model, data, q, i, 1.0));
      for (int c = 0; c < model.dof_count(); ++c) {
        EXPECT_NEAR(data.muscle_length_gradient()[c], fd[c], 2e-8)
            << model.muscle(i).name << " column " << c;
      }
      ++compared[model.muscle(i).name];
    }
  }
  // (GM: a tilted constrained cylinder on the clamp; GAS: an ellipsoid and a torus, with a
  // conditional point. VAS's cylinder never engages at these postures: the planar leg below
  // covers a cylinder on a moving link.)
  for (const std::string name : {"GM", "GAS"}) {
    EXPECT_GE(compared[name], 5) << name << ": too few smooth postures where a wrap engages";
  }
}

TEST(WrapEngineTest, BatchEqualsSingleForWrappedMuscles) {
  for (const WrapMode mode : {WrapMode::kOpenSim, WrapMode::kExact}) {
    const Model model(WrapsFixture(mode));
    std::mt19937 rng(3);
    Eigen::MatrixXd postures(model.dof_count(), 9);
    for (int p = 0; p < postures.cols(); ++p) postures.col(p) = RandomPosture(model, rng);
    StiffnessSet s = model.model_stiffness();
    s.s_t = Vector6d::Constant(1e4);
    for (int c = 0; c < model.dof_count(); ++c) s.s_p[c] = 0.05;
    std::vector<StiffnessSet> sets = {s, s};
    sets[1].s_t *= 3.0;
    Data data(model);
    for (int i = 0; i < model.muscle_count(); ++i) {
      if (model.muscle(i).wraps.empty()) continue;
      std::vector<WrenchResult> batch;
      EvaluateBatch(model, postures, i, sets, batch, 0.7);
      for (int p = 0; p < postures.cols(); ++p) {
        for (size_t k = 0; k < sets.size(); ++k) {
          const WrenchResult one =
              Evaluate(model, data, postures.col(p), i, sets[k], 0.7, SolveOptions{});
          const WrenchResult& b = batch[p * sets.size() + k];
          EXPECT_EQ(b.status, one.status);
          EXPECT_LE((b.wrench - one.wrench).norm(), 1e-9 * (1.0 + one.wrench.norm()))
              << model.muscle(i).name << " posture " << p;
        }
      }
    }
  }
}

// The published rat model (no licence: not in the repository; skipped when absent). The
// quadriceps extend the knee: they shorten as knee_r_flx grows towards extension, so their moment
// arm about it is positive (anatomy, not this program's output). Their straight lines cross the
// knee's wrap surfaces and get the sign wrong at the default posture (-120 deg); wrapped, in both
// modes, it is positive, and the wrapped path is longer than the straight one.
TEST(WrapEngineTest, RatQuadricepsExtendTheKneeOnlyWhenWrapped) {
  const std::string path = "/work/ext/RatHindlimb/models/osim/rat_hindlimb.osim";
  if (!std::ifstream(path)) GTEST_SKIP() << path << " is not here";
  OpenSimImportOptions options;
  options.clamp_body = "pelvis_r";
  options.endpoint_body = "foot_r";
  LimbDescription d = ImportOpenSimFile(path, options).description;
  LimbDescription straight = d;
  for (MuscleSpec& m : straight.muscles) m.wraps.clear();
  const Model wrapped(d), unwrapped(straight);
  d.wrap_mode = WrapMode::kExact;
  const Model exact(d);
  Data a(wrapped), b(unwrapped), c(exact);
  const Eigen::VectorXd q = wrapped.nominal_posture();
  const int knee = Column(wrapped, "knee_r_flx");
  ASSERT_NEAR(q[knee], -2.0944, 1e-4);
  int flipped = 0;
  for (const std::string name : {"R_RF", "R_VL", "R_VI", "R_VM"}) {
    const int i = wrapped.MuscleIndex(name);
    ASSERT_TRUE(ComputeKinematics(unwrapped, b, q, i, 1.0));
    const double straight_arm = -b.muscle_length_gradient()[knee];
    ASSERT_TRUE(ComputeKinematics(wrapped, a, q, i, 1.0));
    const double opensim_arm = -a.muscle_length_gradient()[knee];
    EXPECT_GT(a.muscle_length(), b.muscle_length() + 1e-3) << name;
    ASSERT_TRUE(ComputeKinematics(exact, c, q, i, 1.0));
    const double exact_arm = -c.muscle_length_gradient()[knee];
    EXPECT_GT(opensim_arm, 1e-3) << name;
    EXPECT_GT(exact_arm, 1e-3) << name;
    EXPECT_NEAR(exact_arm, opensim_arm, 2e-4) << name;
    flipped += straight_arm < 0.0;
  }
  EXPECT_EQ(flipped, 4) << "the straight paths' knee moment arms at -120 deg";
}

TEST(WrapEngineTest, WrapModeIsAModelOverride) {
  ModelOverrides o;
  EXPECT_TRUE(o.empty());
  o.wrap = WrapMode::kExact;
  EXPECT_FALSE(o.empty());
  const Model exact(ApplyOverrides(WrapsFixture(WrapMode::kOpenSim), o));
  EXPECT_EQ(exact.description().wrap_mode, WrapMode::kExact);
  EXPECT_EQ(ParseWrapMode("exact"), WrapMode::kExact);
  EXPECT_THROW(ParseWrapMode("shortest"), Error);
}

}  // namespace
}  // namespace isowrench
