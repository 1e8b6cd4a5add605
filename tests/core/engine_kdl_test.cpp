// The engine (the flat compiled chain every kinematics and statics evaluation runs on) against
// orocos KDL, the independent reference: KDL builds its own chain from the description
// (BuildKdlChain) and its solvers give the endpoint pose (ChainFkSolverPos_recursive), the
// endpoint Jacobian (ChainJntToJacSolver) and, with changeRefPoint, the linear Jacobian of a
// point on any link. Muscle length gradients are checked against central differences of the
// muscle length computed from KDL positions.

#include <gtest/gtest.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <map>
#include <random>
#include <sstream>
#include <vector>

#include "model/model_impl.hpp"
#include "test_models.hpp"

namespace isowrench_test {
namespace {

using isowrench::Data;
using isowrench::Model;

// Both sides compose the same frames in a different order: rounding only, a few dozen
// operations on numbers <= 1 (lengths <= 0.6 m): far below 1e-12.
constexpr double kKdlTol = 1e-12;
constexpr int kPostures = 1000;

// KDL's view of a model: its own chain and solvers, and the segment count ending at each link.
class KdlReference {
 public:
  explicit KdlReference(const Model& model)
      : chain_(isowrench::BuildKdlChain(model.description())),
        fk_(chain_),
        jac_(chain_),
        q_(chain_.getNrOfJoints()),
        J_(chain_.getNrOfJoints()) {
    const isowrench::LimbDescription& d = model.description();
    segments_[d.root_link] = 0;
    for (size_t i = 0; i < d.joints.size(); ++i)
      segments_[d.joints[i].child_link] = static_cast<int>(i) + 1;
  }
  void Set(const Eigen::VectorXd& q) {
    for (int i = 0; i < q.size(); ++i) q_(i) = q[i];
  }
  KDL::Frame Pose(int segments) {
    KDL::Frame f = KDL::Frame::Identity();
    if (segments > 0) {
      EXPECT_GE(fk_.JntToCart(q_, f, segments), 0);
    }
    return f;
  }
  Eigen::Matrix<double, 6, Eigen::Dynamic> Jacobian(int segments) {
    KDL::SetToZero(J_);
    if (segments > 0) {
      EXPECT_GE(jac_.JntToJac(q_, J_, segments), 0);
    }
    return J_.data;
  }
  Eigen::Matrix3Xd PointJacobian(const std::string& link, const Eigen::Vector3d& p) {
    const int s = segments_.at(link);
    if (s == 0) return Eigen::Matrix3Xd::Zero(3, q_.rows());
    const KDL::Frame f = Pose(s);
    KDL::SetToZero(J_);
    EXPECT_GE(jac_.JntToJac(q_, J_, s), 0);
    J_.changeRefPoint(f.M * KDL::Vector(p.x(), p.y(), p.z()));
    return J_.data.topRows<3>();
  }
  Eigen::Vector3d Point(const std::string& link, const Eigen::Vector3d& p) {
    const KDL::Vector x = Pose(segments_.at(link)) * KDL::Vector(p.x(), p.y(), p.z());
    return Eigen::Vector3d(x.x(), x.y(), x.z());
  }
  int endpoint_segments() const { return static_cast<int>(chain_.getNrOfSegments()); }
  double MuscleLength(const isowrench::MuscleSpec& muscle) {
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
  std::map<std::string, int> segments_;
};

Eigen::Isometry3d ToEigen(const KDL::Frame& f) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) t.linear()(r, c) = f.M(r, c);
    t.translation()[r] = f.p(r);
  }
  return t;
}

class EngineVsKdl : public ::testing::TestWithParam<std::string> {};

// The checks, for any model; `name` labels failures.
void ExpectPoseAndJacobianEqualKdl(const Model& model, const std::string& name) {
  Data ws(model);
  KdlReference kdl(model);
  std::mt19937 rng(12);
  double worst = 0.0;
  for (int p = 0; p < kPostures; ++p) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    kdl.Set(q);
    const Eigen::Isometry3d pose = ToEigen(kdl.Pose(kdl.endpoint_segments()));
    const Eigen::Isometry3d engine_pose = isowrench::EndpointPose(model, ws, q);
    worst = std::max(worst, (engine_pose.matrix() - pose.matrix()).cwiseAbs().maxCoeff());
    const Eigen::MatrixXd J = kdl.Jacobian(kdl.endpoint_segments());
    worst =
        std::max(worst, (isowrench::EndpointJacobianWorld(model, ws, q) - J).cwiseAbs().maxCoeff());
    // Transducer axes: J_T = blockdiag(R^T, R^T) J_W with R = R_W_T.
    const Eigen::Matrix3d R = isowrench::TransducerRotation(model, ws, q);
    Eigen::MatrixXd J_T(6, J.cols());
    J_T.topRows<3>() = R.transpose() * J.topRows<3>();
    J_T.bottomRows<3>() = R.transpose() * J.bottomRows<3>();
    worst =
        std::max(worst, (isowrench::EndpointJacobian(model, ws, q) - J_T).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst, kKdlTol) << name;
}

void ExpectPointsEqualKdl(const Model& model, const std::string& name) {
  Data ws(model);
  KdlReference kdl(model);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> offset(-0.05, 0.05);
  double worst = 0.0;
  for (int p = 0; p < kPostures / 10; ++p) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    kdl.Set(q);
    for (const std::string& link : model.description().links) {
      const Eigen::Vector3d a(offset(rng), offset(rng), offset(rng));
      worst = std::max(
          worst, (isowrench::PointPosition(model, ws, q, link, a) - kdl.Point(link, a)).norm());
      worst = std::max(
          worst, (isowrench::PointJacobian(model, ws, q, link, a) - kdl.PointJacobian(link, a))
                     .cwiseAbs()
                     .maxCoeff());
    }
  }
  EXPECT_LE(worst, kKdlTol) << name;
}

// dL/dq against central differences of KDL muscle lengths. Step 1e-6: truncation
// h^2/6 |L'''| <= 1e-12 * 0.6 / 6 ~ 1e-13, rounding eps |L| / h ~ 1.3e-10; 1e-8 is 75x that.
void ExpectMuscleGradientEqualKdlDifferences(const Model& model, const std::string& name) {
  Data ws(model);
  KdlReference kdl(model);
  std::mt19937 rng(14);
  constexpr double h = 1e-6;
  for (int p = 0; p < 20; ++p) {
    const Eigen::VectorXd q = RandomPosture(model, rng);
    for (int mi = 0; mi < model.muscle_count(); ++mi) {
      const isowrench::MuscleSpec& spec = model.muscle(mi);
      const isowrench::MuscleTorque mt = isowrench::ComputeMuscleTorque(model, ws, q, mi, 0.5);
      kdl.Set(q);
      EXPECT_NEAR(mt.length, kdl.MuscleLength(spec), kKdlTol);
      for (int i = 0; i < model.dof_count(); ++i) {
        Eigen::VectorXd qp = q, qm = q;
        qp[i] += h;
        qm[i] -= h;
        kdl.Set(qp);
        const double lp = kdl.MuscleLength(spec);
        kdl.Set(qm);
        const double lm = kdl.MuscleLength(spec);
        EXPECT_NEAR(mt.dL_dq[i], (lp - lm) / (2 * h), 1e-8)
            << name << " " << spec.name << " joint " << i;
        EXPECT_NEAR(mt.tau[i], -0.5 * spec.max_force * mt.dL_dq[i], 1e-15 * spec.max_force);
      }
    }
  }
}

TEST_P(EngineVsKdl, EndpointPoseAndJacobianEqualKdlOnRandomPostures) {
  ExpectPoseAndJacobianEqualKdl(LoadModel(GetParam()), GetParam());
}

TEST_P(EngineVsKdl, PointPositionsAndJacobiansOnEveryLinkEqualKdl) {
  ExpectPointsEqualKdl(LoadModel(GetParam()), GetParam());
}

TEST_P(EngineVsKdl, MuscleLengthAndGradientEqualKdlDifferences) {
  ExpectMuscleGradientEqualKdlDifferences(LoadModel(GetParam()), GetParam());
}

// A chain with movable joints of the given kinds, each one the kernel compiles a step for
// (FastJoint::op: revolute or prismatic; axis +x, -x, +y, -y, +z, -z or general; with or without
// a fixed translation and rotation before it), a transducer turning with the last link and a
// muscle from ground over the middle of the chain to the last link.
Model JointKindsModel(const std::vector<int>& ops) {
  const int n = static_cast<int>(ops.size());
  std::ostringstream x;
  x << "<robot name=\"kinds\" xmlns:isowrench=\"urn:isowrench:urdf:1\">\n<link name=\"l0\"/>\n";
  const char* axes[3][2] = {{"1 0 0", "-1 0 0"}, {"0 1 0", "0 -1 0"}, {"0 0 1", "0 0 -1"}};
  const char* general[2] = {"0.48 -0.6 0.64", "-0.6 0.64 0.48"};
  for (int i = 0; i < n; ++i) {
    const int op = ops[static_cast<size_t>(i)];
    const bool revolute = (op & 1) != 0;
    const int kind = (op >> 1) & 3;
    x << "<link name=\"l" << i + 1 << "\"/>\n"
      << "<joint name=\"j" << i << "\" type=\"" << (revolute ? "continuous" : "prismatic")
      << "\"><parent link=\"l" << i << "\"/><child link=\"l" << i + 1 << "\"/>"
      << "<origin xyz=\"" << ((op & 8) != 0 ? "0.01 -0.02 0.015" : "0 0 0") << "\" rpy=\""
      << ((op & 16) != 0 ? "0.3 -0.2 0.5" : "0 0 0") << "\"/><axis xyz=\""
      << (kind == 3 ? general[i % 2] : axes[kind][(op & 32) != 0 ? 1 : 0]) << "\"/>"
      << (revolute ? "" : "<limit lower=\"-0.01\" upper=\"0.01\" effort=\"1\" velocity=\"1\"/>")
      << "</joint>\n";
  }
  x << "<isowrench:transducer link=\"l" << n
    << "\" xyz=\"0.02 0.01 -0.01\" rpy=\"0.1 0.2 0.3\" "
       "axes=\"link\" stiffness=\"1e6 1e6 1e6 100 100 100\" released=\"\"/>\n"
    << "<isowrench:muscle name=\"m\" max_force=\"10\">"
    << "<isowrench:point link=\"l0\" xyz=\"0.05 0.04 0.03\"/>"
    << "<isowrench:point link=\"l" << n / 2 << "\" xyz=\"-0.03 0.02 0.01\"/>"
    << "<isowrench:point link=\"l" << n << "\" xyz=\"0.01 -0.03 0.02\"/></isowrench:muscle>\n"
    << "</robot>\n";
  return Model(isowrench::ReadUrdfString(x.str(), "kinds.urdf"));
}

TEST(EngineVsKdlKinds, EveryCompiledJointKindEqualsKdl) {
  // The 56 kinds a model can have (a general axis has no sign), 14 per chain.
  std::vector<int> kinds;
  for (int op = 0; op < 64; ++op) {
    if (!((op & 32) != 0 && ((op >> 1) & 3) == 3)) kinds.push_back(op);
  }
  ASSERT_EQ(kinds.size(), 56u);
  for (size_t first = 0; first < kinds.size(); first += 14) {
    const std::vector<int> ops(kinds.begin() + static_cast<long>(first),
                               kinds.begin() + static_cast<long>(first) + 14);
    const Model model = JointKindsModel(ops);
    // The chain really holds these kinds, in order.
    const isowrench::FlatChain& chain = model.impl().flat;
    ASSERT_EQ(chain.m, 14);
    for (int k = 0; k < 14; ++k) EXPECT_EQ(chain.joints[k].op, ops[k]) << "joint " << k;
    const std::string name =
        "joint kinds " + std::to_string(ops.front()) + ".." + std::to_string(ops.back());
    ExpectPoseAndJacobianEqualKdl(model, name);
    ExpectPointsEqualKdl(model, name);
    ExpectMuscleGradientEqualKdlDifferences(model, name);
    // The SIMD lanes run the same steps: the batch equals one evaluation at a time.
    std::mt19937 rng(15);
    Eigen::MatrixXd postures(14, 64);
    for (int p = 0; p < postures.cols(); ++p) postures.col(p) = RandomPosture(model, rng);
    const std::vector<isowrench::StiffnessSet> sets = {model.model_stiffness()};
    std::vector<isowrench::WrenchResult> batch;
    isowrench::EvaluateBatch(model, postures, 0, sets, batch);
    Data ws(model);
    for (int p = 0; p < postures.cols(); ++p) {
      const isowrench::WrenchResult one =
          isowrench::Evaluate(model, ws, postures.col(p), 0, sets[0]);
      ASSERT_EQ(batch[p].status, one.status) << name << " posture " << p;
      EXPECT_LE((batch[p].wrench - one.wrench).cwiseAbs().maxCoeff(),
                1e-12 * (1.0 + one.wrench.cwiseAbs().maxCoeff()))
          << name << " posture " << p;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Urdfs, EngineVsKdl, ::testing::ValuesIn(ShippedUrdfs()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param.substr(0, info.param.find('.'));
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

}  // namespace
}  // namespace isowrench_test
