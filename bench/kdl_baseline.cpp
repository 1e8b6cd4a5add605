#include "kdl_baseline.hpp"

#include <map>
#include <string>

#include "model/model_impl.hpp"

namespace isowrench_bench {

KdlBaseline::KdlBaseline(const isowrench::Model& model, int muscle)
    : chain_(isowrench::BuildKdlChain(model.description())),
      fk_(chain_),
      jac_solver_(chain_),
      q_(chain_.getNrOfJoints()),
      jac_(chain_.getNrOfJoints()) {
  const isowrench::MuscleSpec& spec = model.muscle(muscle);
  force_ = spec.max_force;
  // KDL segments ending at each link's frame: 0 for the root, i + 1 for joint i's child.
  const isowrench::LimbDescription& d = model.description();
  std::map<std::string, int> link_segments{{d.root_link, 0}};
  for (size_t i = 0; i < d.joints.size(); ++i)
    link_segments[d.joints[i].child_link] = static_cast<int>(i) + 1;
  for (const isowrench::PathPoint& p : spec.path) {
    point_segments_.push_back(link_segments.at(p.link));
    point_offsets_.emplace_back(p.position.x(), p.position.y(), p.position.z());
  }
  segments_ = static_cast<int>(chain_.getNrOfSegments());
}

isowrench::Vector6d KdlBaseline::Evaluate(const Eigen::VectorXd& q, const isowrench::Vector6d& s_t,
                                          const Eigen::VectorXd& s_p) {
  const int m = static_cast<int>(q.size());
  for (int i = 0; i < m; ++i) q_(i) = q[i];
  // Muscle: positions and linear Jacobians of the path points.
  const size_t n = point_segments_.size();
  std::vector<Eigen::Vector3d> x(n);
  std::vector<Eigen::Matrix3Xd> Jp(n, Eigen::Matrix3Xd::Zero(3, m));
  for (size_t i = 0; i < n; ++i) {
    KDL::Frame frame = KDL::Frame::Identity();
    if (point_segments_[i] > 0) {
      fk_.JntToCart(q_, frame, point_segments_[i]);
      jac_solver_.JntToJac(q_, jac_, point_segments_[i]);
      jac_.changeRefPoint(frame.M * point_offsets_[i]);
      Jp[i] = jac_.data.topRows<3>();
    }
    const KDL::Vector p = frame * point_offsets_[i];
    x[i] = Eigen::Vector3d(p.x(), p.y(), p.z());
  }
  Eigen::VectorXd dL = Eigen::VectorXd::Zero(m);
  for (size_t i = 1; i < n; ++i) {
    const Eigen::Vector3d u = (x[i] - x[i - 1]).normalized();
    dL += (Jp[i] - Jp[i - 1]).transpose() * u;
  }
  const Eigen::VectorXd tau = -force_ * dL;
  // Endpoint Jacobian and the statics.
  jac_solver_.JntToJac(q_, jac_, segments_);
  const Eigen::MatrixXd J = jac_.data;
  Eigen::MatrixXd K = J.transpose() * s_t.asDiagonal() * J;
  K.diagonal() += s_p;
  const Eigen::VectorXd dtheta = K.ldlt().solve(tau);
  return s_t.cwiseProduct(J * dtheta);
}

}  // namespace isowrench_bench
