// Moving and conditional muscle path points (PathPoint::moving, PathPoint::active_coordinate):
// the pre-pass before the kinematics kernel and the extra gradient term after it, for muscles
// that have such points (FastMuscle::dynamic); other muscles never reach this file.
//
// A moving component adds direction * f(clamp(q_c, lower, upper)) to its point (in the point's
// frame), so the length gains dL/dq_c = pull . R direction f'(q_c) inside [lower, upper] and
// nothing outside, R being the world rotation of the point's frame. An inactive conditional
// point is skipped by the segments (its pull is 0, so the sweep ignores it).

#include <algorithm>
#include <cmath>
#include <memory>

#include "fast/fast_impl.hpp"

namespace isowrench {

void PreparePathPoints(const FastMuscle& muscle, const double* q, Data::Impl& ws) {
  const int n = static_cast<int>(muscle.points.size());
  for (int i = 0; i < n; ++i) ws.local[i] = muscle.points[i].position;
  for (size_t j = 0; j < muscle.moving.size(); ++j) {
    const FastMovingComponent& c = muscle.moving[j];
    const double x = q[c.column];
    const bool inside = x >= c.lower && x <= c.upper;
    ws.local[c.point] += c.direction * c.function.Value(std::clamp(x, c.lower, c.upper));
    ws.moving_slope[j] = inside ? c.function.Derivative(x) : 0.0;
  }
  ws.active_count = 0;
  for (int i = 0; i < muscle.path_points; ++i) {  // (not the wraps' tangent-point slots)
    const FastPathPoint& p = muscle.points[i];
    if (p.active_column < 0 ||
        (q[p.active_column] >= p.active_lower && q[p.active_column] <= p.active_upper)) {
      ws.active[ws.active_count++] = i;
    } else {
      ws.pulls[i] = Zero3<double>();
    }
  }
}

bool ActivePathPulls(Data::Impl& ws, double* length) {
  double total = 0.0;
  if (ws.active_count == 0) {  // no muscle (a large chain's kinematics functions run this)
    *length = 0.0;
    return true;
  }
  Eigen::Vector3d before = Eigen::Vector3d::Zero();  // u of the previous segment
  for (int j = 1; j < ws.active_count; ++j) {
    const Eigen::Vector3d segment = ToEigen(ws.points[ws.active[j]] - ws.points[ws.active[j - 1]]);
    const double l = segment.norm();
    if (!(l >= kFastMinSegmentLength)) {
      *length = total;
      return false;
    }
    const Eigen::Vector3d u = segment / l;
    total += l;
    ws.pulls[ws.active[j - 1]] = FromEigen(before - u);
    before = u;
  }
  ws.pulls[ws.active[ws.active_count - 1]] = FromEigen(before);
  *length = total;
  return true;
}

bool WrappedPathPulls(const FlatChain& chain, const FastMuscle& muscle, Data::Impl& ws,
                      double* length) {
  if (!ws.wrap) ws.wrap = std::make_unique<WrapWorkspace>();  // (a Data of another model)
  WrapWorkspace& w = *ws.wrap;
  WrapPathInput& in = w.input;
  const int n = muscle.path_points;
  const int n_wraps = static_cast<int>(muscle.wraps.size());
  if (w.muscle != &muscle || w.chain_id != chain.id) {  // this muscle's wraps
    w.muscle = &muscle;
    w.chain_id = chain.id;
    in.points.resize(static_cast<size_t>(n));
    in.active.resize(static_cast<size_t>(n));
    in.wraps.resize(static_cast<size_t>(n_wraps));
    for (int j = 0; j < n_wraps; ++j) in.wraps[j] = muscle.wraps[j].wrap;
  }
  // The active points (a coincident pair: no path, as ActivePathPulls).
  std::fill(in.active.begin(), in.active.end(), 0);
  for (int k = 0; k < ws.active_count; ++k) {
    const int i = ws.active[k];
    in.active[i] = 1;
    if (k > 0 &&
        !(ToEigen(ws.points[i] - ws.points[ws.active[k - 1]]).norm() >= kFastMinSegmentLength)) {
      *length = 0.0;
      return false;
    }
  }
  for (int i = 0; i < n; ++i) in.points[i] = ToEigen(ws.points[i]);
  for (int j = 0; j < n_wraps; ++j) {  // X_W_S from the first slot's frame
    const FastWrap& f = muscle.wraps[j];
    Eigen::Isometry3d& X = in.wraps[j].X_W_S;
    X.linear() = ToEigen(ws.point_rotation[f.slot].data()) * f.rotation;
    X.translation() = ToEigen(ws.points[f.slot]);
  }
  WrappedPath& out = w.path;
  ComputeWrappedPath(in, muscle.wrap_mode, out);
  for (int i = 0; i < n; ++i) ws.pulls[i] = FromEigen(out.point_pull[i]);
  for (int j = 0; j < n_wraps; ++j) {
    const int slot = muscle.wraps[j].slot;
    const WrappedPath::Wrap& r = out.wraps[j];
    ws.points[slot] = FromEigen(r.r1);
    ws.points[slot + 1] = FromEigen(r.r2);
    ws.pulls[slot] = r.wrapped ? FromEigen(r.pull_r1) : Zero3<double>();
    ws.pulls[slot + 1] = r.wrapped ? FromEigen(r.pull_r2) : Zero3<double>();
  }
  *length = out.length;
  return true;
}

void AddMovingPointTerms(const FastMuscle& muscle, Data::Impl& ws, double minus_force) {
  for (size_t j = 0; j < muscle.moving.size(); ++j) {
    const FastMovingComponent& c = muscle.moving[j];
    if (ws.moving_slope[j] == 0.0) continue;  // clamped, constant, or an inactive point's pull 0
    const double term =
        ToEigen(ws.pulls[c.point]).dot(ToEigen(ws.point_rotation[c.point].data()) * c.direction) *
        ws.moving_slope[j];
    ws.dL[c.column] += term;
    ws.tau[c.column] = minus_force * ws.dL[c.column];
  }
}

}  // namespace isowrench
