// Chains of any size (issue 25, item 1): the engine on synthetic chains past the old 16-joint
// limit (up to 66 movable joints and 33 coordinates, couplings included) against independent
// references: orocos KDL's pose and Jacobian of the chain of every description joint (the
// couplings applied by the test: q_joint = f(q), J = J_joints C with C = df/dq), central
// differences of the muscle length measured on KDL's frames, and the batch equal to single
// evaluations; the 16-joint boundary both sides; constant couplings folded into fixed
// transforms equal to the same model with those joints written as fixed joints.

#include "fast/large_chain.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "isowrench/isowrench.hpp"
#include "model/model_impl.hpp"

namespace large_chain_test {
namespace {

using isowrench::Data;
using isowrench::Model;
using isowrench::StaticsStatus;
using isowrench::StiffnessSet;
using isowrench::WrenchResult;

constexpr double kEps = std::numeric_limits<double>::epsilon();

// KDL's view of a model with couplings: its own chain of every description joint, each movable
// one set to q_joint = coupling(q of its coordinate) by the test.
class CoupledKdl {
 public:
  explicit CoupledKdl(const Model& model)
      : chain_(isowrench::BuildKdlChain(model.description())),
        fk_(chain_),
        jac_(chain_),
        q_(chain_.getNrOfJoints()),
        J_(chain_.getNrOfJoints()) {
    const isowrench::LimbDescription& d = model.description();
    segments_[d.root_link] = 0;
    for (size_t i = 0; i < d.joints.size(); ++i) {
      segments_[d.joints[i].child_link] = static_cast<int>(i) + 1;
      if (d.joints[i].type == isowrench::JointType::kFixed) continue;
      const std::string& c =
          d.joints[i].coordinate.empty() ? d.joints[i].name : d.joints[i].coordinate;
      movable_.push_back(&d.joints[i]);
      column_.push_back(model.JointIndex(c));
    }
  }
  void Set(const Eigen::VectorXd& q) {
    for (size_t k = 0; k < movable_.size(); ++k) q_(k) = movable_[k]->coupling.Value(q[column_[k]]);
  }
  KDL::Frame Pose(int segments) {
    KDL::Frame f = KDL::Frame::Identity();
    if (segments > 0) {
      EXPECT_GE(fk_.JntToCart(q_, f, segments), 0);
    }
    return f;
  }
  int endpoint_segments() const { return static_cast<int>(chain_.getNrOfSegments()); }
  // J (6 x coordinates, world axes, reference point the endpoint) = J_joints C at q.
  Eigen::MatrixXd Jacobian(const Eigen::VectorXd& q) {
    Set(q);
    KDL::SetToZero(J_);
    EXPECT_GE(jac_.JntToJac(q_, J_), 0);
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(movable_.size()), q.size());
    for (size_t k = 0; k < movable_.size(); ++k) {
      C(static_cast<Eigen::Index>(k), column_[k]) = movable_[k]->coupling.Derivative(q[column_[k]]);
    }
    return J_.data * C;
  }
  Eigen::Vector3d Point(const std::string& link, const Eigen::Vector3d& p) {
    const KDL::Vector x = Pose(segments_.at(link)) * KDL::Vector(p.x(), p.y(), p.z());
    return Eigen::Vector3d(x.x(), x.y(), x.z());
  }
  double MuscleLength(const Eigen::VectorXd& q, const isowrench::MuscleSpec& muscle) {
    Set(q);
    double length = 0.0;
    for (size_t i = 1; i < muscle.path.size(); ++i) {
      length += (Point(muscle.path[i].link, muscle.path[i].position) -
                 Point(muscle.path[i - 1].link, muscle.path[i - 1].position))
                    .norm();
    }
    return length;
  }

 private:
  KDL::Chain chain_;
  KDL::ChainFkSolverPos_recursive fk_;
  KDL::ChainJntToJacSolver jac_;
  KDL::JntArray q_;
  KDL::Jacobian J_;
  std::vector<const isowrench::JointSpec*> movable_;
  std::vector<int> column_;
  std::map<std::string, int> segments_;
};

Eigen::VectorXd RandomPosture(const Model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-2.5, 2.5);
  Eigen::VectorXd q(model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) q[i] = angle(rng);
  return q;
}

double MaxAbs(const Eigen::MatrixXd& a) { return a.size() == 0 ? 0.0 : a.cwiseAbs().maxCoeff(); }

// The engine's pose, Jacobian (transducer axes), length, dL/dq and tau on `postures` random
// postures, against KDL and central differences of KDL lengths; and the wrench against the
// full report's eigen-solve (EvaluateWrench), where that is clearly regular.
void ExpectEngineEqualsReferences(const Model& model, int postures, unsigned seed) {
  SCOPED_TRACE(model.name() + " (" + std::to_string(model.impl().flat.m) + " movable joints, " +
               std::to_string(model.dof_count()) + " coordinates)");
  Data ws(model);
  CoupledKdl kdl(model);
  std::mt19937 rng(seed);
  const StiffnessSet stiffness = model.model_stiffness();
  constexpr double h = 1e-6;
  for (int p = 0; p < postures; ++p) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    kdl.Set(q);
    const KDL::Frame tip = kdl.Pose(kdl.endpoint_segments());
    Eigen::Matrix3d R_tip;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R_tip(r, c) = tip.M(r, c);
    const Eigen::Vector3d p_tip(tip.p.x(), tip.p.y(), tip.p.z());
    // (the endpoint segment has no rotation: R_W_T = R_tip * rotation, the transducer turning
    // with the last link)
    const Eigen::Matrix3d R = R_tip * model.transducer().rotation;
    const Eigen::MatrixXd J_world = kdl.Jacobian(q);
    Eigen::MatrixXd J_T(6, J_world.cols());
    J_T.topRows<3>() = R.transpose() * J_world.topRows<3>();
    J_T.bottomRows<3>() = R.transpose() * J_world.bottomRows<3>();
    for (int mu = 0; mu < model.muscle_count(); ++mu) {
      SCOPED_TRACE("posture " + std::to_string(p) + ", muscle " + model.muscle(mu).name);
      ASSERT_TRUE(isowrench::ComputeKinematics(model, ws, q, mu, 0.8));
      // Sums of ~70 products of numbers <= 1 in another order: a few hundred ulps at most.
      EXPECT_LE(MaxAbs(ws.jacobian() - J_T), 1e-13) << "J_T_E";
      EXPECT_LE((ws.endpoint_position() - p_tip).norm(), 1e-14) << "endpoint";
      EXPECT_LE(MaxAbs(ws.transducer_rotation() - R), 1e-13) << "R_W_T";
      const isowrench::MuscleSpec& spec = model.muscle(mu);
      EXPECT_NEAR(ws.muscle_length(), kdl.MuscleLength(q, spec), 1e-14);
      // Central differences: truncation h^2 |L'''| / 6 ~ 1e-13, rounding eps L / h ~ 1e-11.
      Eigen::VectorXd dL(model.dof_count());
      for (int i = 0; i < model.dof_count(); ++i) {
        Eigen::VectorXd qp = q, qm = q;
        qp[i] += h;
        qm[i] -= h;
        dL[i] = (kdl.MuscleLength(qp, spec) - kdl.MuscleLength(qm, spec)) / (2 * h);
      }
      EXPECT_LE(MaxAbs(ws.muscle_length_gradient() - dL), 1e-9) << "dL/dq";
      EXPECT_LE(MaxAbs(ws.tau() + 0.8 * spec.max_force * ws.muscle_length_gradient()),
                1e-15 * spec.max_force)
          << "tau";
      // The statics: the Cholesky of the evaluation against the full report's eigen-solve.
      const WrenchResult w = isowrench::SolveStatics(model, ws, stiffness);
      const isowrench::WrenchEvaluation ref = isowrench::EvaluateWrench(model, q, spec.name, 0.8);
      ASSERT_EQ(ref.statics.status, StaticsStatus::kOk);
      EXPECT_EQ(w.status, StaticsStatus::kOk);
      const double tol = std::max(1e-12, 64 * kEps * ref.statics.k_condition);
      EXPECT_LE(MaxAbs(w.wrench - ref.statics.wrench), tol * MaxAbs(ref.statics.wrench))
          << "W: " << w.wrench.transpose() << " vs " << ref.statics.wrench.transpose();
      EXPECT_LE(MaxAbs(ws.dtheta() - ref.statics.dtheta), tol * MaxAbs(ref.statics.dtheta));
      // Evaluate (kinematics and statics in one call) is the same evaluation.
      // (compiled apart, the two may fuse multiply-adds differently: equal to rounding)
      const WrenchResult e = isowrench::Evaluate(model, ws, q, mu, stiffness, 0.8);
      EXPECT_EQ(e.status, w.status);
      EXPECT_LE(MaxAbs(e.wrench - w.wrench), tol * MaxAbs(w.wrench));
    }
  }
}

// EvaluateBatch (the lanes: four postures per register, then one posture and four sets) equals
// single evaluations: the same statuses, wrenches to 16 m eps cond(K) (the lanes may fuse
// multiply-adds differently).
void ExpectBatchEqualsSingle(const Model& model, unsigned seed) {
  SCOPED_TRACE(model.name());
  std::mt19937 rng(seed);
  constexpr int kPostures = 9;  // two groups of four and a tail of one
  Eigen::MatrixXd postures(model.dof_count(), kPostures);
  for (int p = 0; p < kPostures; ++p) postures.col(p) = RandomPosture(model, rng);
  std::vector<StiffnessSet> sets;
  sets.push_back(model.model_stiffness());
  StiffnessSet soft = model.model_stiffness();
  soft.s_t.tail<3>() *= 1e-2;
  sets.push_back(soft);
  StiffnessSet singular = model.model_stiffness();  // no S_p: K = J^T S_t J has rank <= 6
  singular.s_p.setZero();
  sets.push_back(singular);
  for (int threads : {1, 2}) {
    for (int mu = 0; mu < model.muscle_count(); ++mu) {
      isowrench::BatchOptions options;
      options.threads = threads;
      std::vector<WrenchResult> batch;
      isowrench::EvaluateBatch(model, postures, mu, sets, batch, 0.6, options);
      ASSERT_EQ(batch.size(), static_cast<size_t>(kPostures) * sets.size());
      Data ws(model);
      for (int p = 0; p < kPostures; ++p) {
        for (size_t s = 0; s < sets.size(); ++s) {
          SCOPED_TRACE("posture " + std::to_string(p) + ", set " + std::to_string(s) + ", muscle " +
                       std::to_string(mu) + ", threads " + std::to_string(threads));
          const WrenchResult single =
              isowrench::Evaluate(model, ws, postures.col(p), mu, sets[s], 0.6);
          const WrenchResult& b = batch[static_cast<size_t>(p) * sets.size() + s];
          ASSERT_EQ(b.status, single.status);
          ASSERT_EQ(b.self_motion_count, single.self_motion_count);
          double tolerance = 1e-12;
          if (single.status == StaticsStatus::kOk) {
            const Eigen::MatrixXd J = ws.jacobian();
            const Eigen::MatrixXd K = J.transpose() * sets[s].s_t.asDiagonal() * J +
                                      Eigen::MatrixXd(sets[s].s_p.asDiagonal());
            const Eigen::VectorXd lambda =
                Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K).eigenvalues();
            tolerance = std::max(tolerance, 16.0 * static_cast<double>(K.rows()) * kEps *
                                                lambda.maxCoeff() / lambda.minCoeff());
          }
          EXPECT_LE(MaxAbs(b.wrench - single.wrench), tolerance * MaxAbs(single.wrench));
        }
      }
    }
  }
}

// 33 coordinates, each with its own revolute joint and a driven one (mimic, spline, a spline of
// the previous coordinate): 66 movable joints; and the same chain without couplings (33).
TEST(LargeChain, SixtySixJointsOfThirtyThreeCoordinatesEqualKdlAndLengthDifferences) {
  const Model coupled = large_chain::Model({33, true, 0, false});
  ASSERT_EQ(coupled.impl().flat.m, 66);
  ASSERT_EQ(coupled.dof_count(), 33);
  ASSERT_TRUE(coupled.impl().flat.large);
  ExpectEngineEqualsReferences(coupled, 4, 101);
  const Model plain = large_chain::Model({33, false, 0, false});
  ASSERT_EQ(plain.impl().flat.m, 33);
  ExpectEngineEqualsReferences(plain, 4, 102);
}

TEST(LargeChain, BatchEqualsSingleOnSixtySixJoints) {
  ExpectBatchEqualsSingle(large_chain::Model({33, true, 0, false}), 103);
}

// The old limit was 16 movable joints and 16 coordinates (and 64 path points a muscle); the
// workspace's fixed-size shape still ends there. Both sides of each boundary, against KDL and
// the batch: 16 and 17 coordinates without couplings, 8 coordinates on 16 joints and 9 on 18,
// and 64 and 65 path points.
TEST(LargeChain, SixteenJointBoundaryBothSides) {
  struct Case {
    large_chain::Options options;
    int joints;
    bool large;
  };
  // (extra points fill the long muscle to 64 and 65)
  const int points =
      static_cast<int>(large_chain::Model({8, false, 0, false}).muscle(0).path.size());
  const std::vector<Case> cases = {
      {{16, false, 0, false}, 16, false},         {{17, false, 0, false}, 17, true},
      {{8, true, 0, false}, 16, false},           {{9, true, 0, false}, 18, true},
      {{8, false, 64 - points, false}, 8, false}, {{8, false, 65 - points, false}, 8, true}};
  for (const Case& c : cases) {
    const Model model = large_chain::Model(c.options);
    SCOPED_TRACE(model.name() + " with " + std::to_string(model.muscle(0).path.size()) + " points");
    EXPECT_EQ(model.impl().flat.m, c.joints);
    EXPECT_EQ(model.impl().flat.large, c.large);
    ExpectEngineEqualsReferences(model, 2, 104);
    ExpectBatchEqualsSingle(model, 105);
  }
  // The path points of the two muscle sizes.
  EXPECT_EQ(large_chain::Model({8, false, 64 - points, false}).muscle(0).path.size(), 64u);
  EXPECT_EQ(large_chain::Model({8, false, 65 - points, false}).muscle(0).path.size(), 65u);
}

// The case that failed on the imported rat: a 14-joint limb with 3 base dofs added by
// WithBaseStiffness is 17 movable joints; it evaluates, and its base columns hold the base.
TEST(LargeChain, BaseDofsPastSixteenJointsEvaluate) {
  const isowrench::LimbDescription limb = large_chain::Description({7, true, 0, false});
  const Model model(isowrench::WithBaseStiffness(limb, 1e5));
  ASSERT_EQ(model.impl().flat.m, 17);
  ASSERT_EQ(model.dof_count(), 10);
  ExpectEngineEqualsReferences(model, 3, 106);
  Data ws(model);
  const WrenchResult w =
      isowrench::Evaluate(model, ws, model.nominal_posture(), 0, model.model_stiffness());
  ASSERT_EQ(w.status, StaticsStatus::kOk);
  // The base dofs are the first three columns, each held by 1e5 N/m: S_p dtheta is their share
  // of tau - J^T W (the equilibrium K dtheta = tau).
  const Eigen::VectorXd residual = ws.jacobian().transpose() * w.wrench +
                                   model.model_stiffness().s_p.cwiseProduct(ws.dtheta()) - ws.tau();
  EXPECT_LE(MaxAbs(residual), 1e-9 * MaxAbs(ws.tau()));
  EXPECT_GT(MaxAbs(ws.dtheta().head<3>()), 0.0);
}

// A Data made for one model runs another one only if it fits; else an Error naming both.
TEST(LargeChain, DataOfAnotherSizeIsRefusedNamingBothModels) {
  const Model small = large_chain::Model({8, false, 0, false});
  const Model large = large_chain::Model({20, true, 0, false});
  Data ws(small);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(large.dof_count());
  try {
    isowrench::ComputeKinematics(large, ws, q, 0);
    FAIL() << "no error";
  } catch (const isowrench::Error& e) {
    EXPECT_NE(std::string(e.what()).find("chain_8"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("chain_20_coupled"), std::string::npos) << e.what();
  }
  EXPECT_THROW(isowrench::Evaluate(large, ws, q, 0, large.model_stiffness()), isowrench::Error);
  EXPECT_EQ(isowrench::SolveStatics(large, ws, large.model_stiffness()).status,
            StaticsStatus::kInvalidInput);
  // A copy of the model (or another model of the same sizes) runs on it.
  const Model copy = small;
  Data other(large_chain::Model({8, false, 0, false}));
  EXPECT_TRUE(isowrench::ComputeKinematics(copy, other, Eigen::VectorXd::Zero(8), 0));
}

// Constant couplings -------------------------------------------------------------------------

isowrench::Function Spline(std::vector<double> x, std::vector<double> y) {
  return isowrench::Function::SimmSpline(std::move(x), std::move(y));
}

bool Constant(const isowrench::Function& f, double lower, double upper, double* value) {
  return isowrench::ConstantCoupling(f, lower, upper, value);
}

TEST(ConstantCoupling, EachFunctionKindOverItsRangeOrAllReals) {
  using isowrench::Function;
  const double inf = std::numeric_limits<double>::infinity();
  double v = -1;
  EXPECT_TRUE(Constant(Function::Constant(0.25), -1, 1, &v));
  EXPECT_EQ(v, 0.25);
  EXPECT_TRUE(Constant(Function::Linear(0.0, -0.5), -inf, inf, &v));
  EXPECT_EQ(v, -0.5);
  EXPECT_FALSE(Constant(Function::Linear(1e-12, 0.0), -1, 1, &v));
  EXPECT_TRUE(Constant(Function::Multiplier(Spline({0, 1, 2}, {0, 1, 4}), 0.0), -1, 1, &v));
  EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(Constant(Function::Multiplier(Function::Constant(2.0), 3.0), -1, 1, &v));
  EXPECT_EQ(v, 6.0);
  EXPECT_TRUE(Constant(Function::Polynomial({0.0, 0.0, 3.0}), -inf, inf, &v));
  EXPECT_EQ(v, 3.0);
  EXPECT_FALSE(Constant(Function::Polynomial({1e-20, 3.0}), -1, 1, &v));
  // Knot values all 0 (the unilateral rat's ankle translations): constant everywhere, the end
  // slopes included (OpenSim extrapolates linearly with them).
  EXPECT_TRUE(Constant(Spline({-0.5, 0, 0.5, 1}, {0, 0, 0, 0}), -inf, inf, &v));
  EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(Constant(Function::PiecewiseLinear({-1, 2, 3}, {0.3, 0.3, 0.3}), -inf, inf, &v));
  EXPECT_EQ(v, 0.3);
  EXPECT_TRUE(Constant(Function::NaturalCubicSpline({-1, 2, 3}, {0.3, 0.3, 0.3}), -2, 9, &v));
  // Flat between -1 and 1 only: constant over a range inside, not over one that reaches the
  // rising intervals (touching them counts: at a knot OpenSim may take either interval), nor
  // over all reals (an infinite end of the range).
  const Function middle = Function::PiecewiseLinear({-2, -1, 0, 1, 2}, {1, 0, 0, 0, 2});
  EXPECT_TRUE(Constant(middle, -0.5, 0.5, &v));
  EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(Constant(middle, -0.99, 0.99, &v));
  EXPECT_FALSE(Constant(middle, -1.0, 0.5, &v));
  EXPECT_FALSE(Constant(middle, -0.5, 1.5, &v));
  EXPECT_FALSE(Constant(middle, -inf, inf, &v));
  EXPECT_FALSE(Constant(middle, -0.5, inf, &v));  // (half-infinite: over all reals)
  // Flat over the knots but extrapolated with a slope: constant inside the knots only.
  const Function sloped_ends = Function::PiecewiseLinear({-3, -2, 2, 3}, {-1, 0, 0, 1});
  EXPECT_TRUE(Constant(sloped_ends, -1, 1, &v));
  EXPECT_FALSE(Constant(sloped_ends, -1, 2.5, &v));
  // A range wholly outside the knots: the extrapolation's slope decides.
  EXPECT_FALSE(Constant(sloped_ends, -5, -4, &v));
  EXPECT_FALSE(Constant(sloped_ends, 4, 5, &v));
  const Function flat_ends = Function::PiecewiseLinear({-3, -2, 2, 3}, {0, 0, 1, 1});
  EXPECT_TRUE(Constant(flat_ends, -5, -4, &v));
  EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(Constant(flat_ends, 4, 5, &v));
  EXPECT_EQ(v, 1.0);
  // A SimmSpline through a flat middle is not flat there (its cubics are not local): not
  // constant, whatever the range.
  EXPECT_FALSE(Constant(Spline({-2, -1, 0, 1, 2}, {1, 0, 0, 0, 2}), -0.5, 0.5, &v));
  // A degenerate range (lower == upper) is no range: over all reals.
  EXPECT_FALSE(Constant(middle, 0.0, 0.0, &v));
}

// A knee whose coordinate drives two joints with constant couplings: a prismatic one through a
// SimmSpline of zeros (constant everywhere) and a revolute one through a piecewise-linear
// function flat over the coordinate's range [-1, 1] (and to +-1.2) but not beyond. The model folds
// both into the fixed transforms; it equals (to rounding) the same model with them written as fixed
// joints at their constant, inside the range. With the range removed the second one is not
// constant (over all reals) and stays a joint, equal inside the range, different outside.
isowrench::LimbDescription KneeWithConstantJoints(bool range) {
  using isowrench::JointType;
  isowrench::LimbDescription d = large_chain::Description({4, false, 0, false});
  const auto after = std::find_if(d.joints.begin(), d.joints.end(),
                                  [](const isowrench::JointSpec& j) { return j.name == "q1"; });
  const size_t at = static_cast<size_t>(after - d.joints.begin()) + 1;
  isowrench::JointSpec zero;
  zero.name = "zero_tx";
  zero.type = JointType::kPrismatic;
  zero.axis = Eigen::Vector3d(0.6, 0.0, 0.8);
  zero.origin = large_chain::Pose(0.003, 0.0, 0.001, 0.2, 0.0, 0.0);
  zero.coordinate = "q1";
  zero.coupling = Spline({-3, -1, 0, 1, 3}, {0, 0, 0, 0, 0});
  isowrench::JointSpec flat;
  flat.name = "flat_rz";
  flat.type = JointType::kRevolute;
  flat.axis = Eigen::Vector3d::UnitZ();
  flat.origin = large_chain::Pose(0.002, 0.001, 0.0, 0.0, 0.3, 0.0);
  flat.coordinate = "q1";
  flat.coupling =
      isowrench::Function::PiecewiseLinear({-2, -1.2, 0, 1.2, 2}, {-0.4, 0.3, 0.3, 0.3, 1});
  // Relink: q1 -> zero_tx -> flat_rz -> the rest.
  const std::string next_parent = d.joints[at - 1].child_link;
  zero.parent_link = next_parent;
  zero.child_link = "zero_link";
  flat.parent_link = "zero_link";
  flat.child_link = "flat_link";
  d.joints[at].parent_link = "flat_link";
  d.joints.insert(d.joints.begin() + static_cast<std::ptrdiff_t>(at), {zero, flat});
  d.links.push_back("zero_link");
  d.links.push_back("flat_link");
  d.muscles[1].path.push_back({"flat_link", Eigen::Vector3d(0.001, 0.002, 0.0)});
  std::swap(d.muscles[1].path[1], d.muscles[1].path[2]);  // (the tip last)
  d = isowrench::NormalizeCoordinates(d);
  if (range) {
    for (isowrench::CoordinateSpec& c : d.coordinates) {
      if (c.name == "q1") {
        c.lower = -1.0;
        c.upper = 1.0;
      }
    }
  }
  return d;
}

// The same knee with the constant joints written as fixed joints at their constants.
isowrench::LimbDescription KneeWithFixedJoints() {
  isowrench::LimbDescription d = KneeWithConstantJoints(true);
  for (isowrench::JointSpec& j : d.joints) {
    if (j.name == "zero_tx") {
      j.type = isowrench::JointType::kFixed;  // translation 0: origin unchanged
    } else if (j.name == "flat_rz") {
      j.origin = j.origin * Eigen::AngleAxisd(0.3, j.axis);
      j.type = isowrench::JointType::kFixed;
    }
    if (j.type == isowrench::JointType::kFixed) {
      j.coordinate.clear();
      j.coupling = isowrench::Function::Linear(1.0, 0.0);
    }
  }
  return isowrench::NormalizeCoordinates(d);
}

// Everything a caller sees of one evaluation.
struct Seen {
  Eigen::MatrixXd J;
  Eigen::VectorXd tau, dL;
  Eigen::Vector3d endpoint;
  double length = 0.0;
  Eigen::VectorXd wrench;
};
Seen Evaluate(const Model& model, const Eigen::VectorXd& q, int muscle) {
  Data ws(model);
  const WrenchResult w = isowrench::Evaluate(model, ws, q, muscle, model.model_stiffness(), 0.9);
  EXPECT_EQ(w.status, StaticsStatus::kOk);
  return {ws.jacobian(),          ws.tau(),           ws.muscle_length_gradient(),
          ws.endpoint_position(), ws.muscle_length(), w.wrench};
}
double Difference(const Seen& a, const Seen& b) {
  return std::max({MaxAbs(a.J - b.J), MaxAbs(a.tau - b.tau), MaxAbs(a.dL - b.dL),
                   (a.endpoint - b.endpoint).norm(), std::abs(a.length - b.length),
                   MaxAbs(a.wrench - b.wrench) / std::max(1.0, MaxAbs(b.wrench))});
}

TEST(ConstantCoupling, FoldedJointsEqualTheSameModelWithThemWrittenAsFixedJoints) {
  const Model folded(KneeWithConstantJoints(true));
  const Model fixed(KneeWithFixedJoints());
  const Model unranged(KneeWithConstantJoints(false));
  EXPECT_EQ(folded.impl().flat.folded_joints, (std::vector<std::string>{"zero_tx", "flat_rz"}));
  EXPECT_EQ(unranged.impl().flat.folded_joints, (std::vector<std::string>{"zero_tx"}));
  EXPECT_EQ(folded.impl().flat.m, fixed.impl().flat.m);
  EXPECT_EQ(unranged.impl().flat.m, fixed.impl().flat.m + 1);
  ASSERT_EQ(folded.dof_count(), fixed.dof_count());
  std::mt19937 rng(107);
  std::uniform_real_distribution<double> angle(-2.5, 2.5), inside(-0.95, 0.95);
  const int q1 = folded.JointIndex("q1");
  for (int p = 0; p < 20; ++p) {
    Eigen::VectorXd q(folded.dof_count());
    for (int i = 0; i < q.size(); ++i) q[i] = angle(rng);
    q[q1] = inside(rng);
    for (int mu = 0; mu < 2; ++mu) {
      // Rounding only: the folded transform is the same product in another order.
      EXPECT_LE(Difference(Evaluate(folded, q, mu), Evaluate(fixed, q, mu)), 1e-13);
      EXPECT_LE(Difference(Evaluate(unranged, q, mu), Evaluate(fixed, q, mu)), 1e-13);
    }
    // Outside the range the flat joint turns (OpenSim extrapolates the function): the model
    // without a range follows it, the folded one holds its constant.
    q[q1] = 1.6;
    EXPECT_LE(Difference(Evaluate(folded, q, 1), Evaluate(fixed, q, 1)), 1e-13);
    EXPECT_GT(Difference(Evaluate(unranged, q, 1), Evaluate(fixed, q, 1)), 1e-4);
  }
}

}  // namespace
}  // namespace large_chain_test
