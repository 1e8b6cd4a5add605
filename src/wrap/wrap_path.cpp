// A muscle's wrapped path: OpenSim's GeometryPath::applyWrapObjects (which segment of a range a
// wrap acts on, the passes, the order of several wraps), calcPathLengthChange and
// calcLengthAfterPathComputation (opensim-core OpenSim/Simulation/Model/GeometryPath.cpp), and
// the pulls of GeometryPath::produceForces (docs/opensim.md "Wrapping").

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "isowrench/error.hpp"
#include "wrap/wrap_impl.hpp"

namespace isowrench {
namespace {

using wrap_impl::OsSegment;
using wrap_impl::V3;

// Two path lengths closer than this end the passes over several wraps (GeometryPath.cpp).
constexpr double kPassTolerance = 0.0005;
// Most passes over several wraps (GeometryPath.cpp maxIterations).
constexpr int kMaxPasses = 8;
// Exact mode: the passes go on until the path is stationary as a whole (each wrap's tangent
// points stationary given its neighbours, which the other wraps move), so that -dL/dq is the
// pull formula: lengths of two passes within this (m), at most kExactMaxPasses passes.
constexpr double kExactPassTolerance = 1e-13;
constexpr int kExactMaxPasses = 200;
// A straight segment shorter than this has no direction (the engine's kFastMinSegmentLength).
constexpr double kMinSegment = 1e-9;

OsSegment OpenSimSegment(const WrapSurface& s, const V3& p1, const V3& p2, WrapMethod method,
                         bool single_wrap) {
  switch (s.shape) {
    case WrapShape::kCylinder:
      return wrap_impl::OpenSimCylinder(s.radius, s.length, s.quadrant, p1, p2, single_wrap);
    case WrapShape::kSphere: return wrap_impl::OpenSimSphere(s.radius, s.quadrant, p1, p2);
    case WrapShape::kEllipsoid:
      return wrap_impl::OpenSimEllipsoid(s.radii, s.quadrant, method, p1, p2);
    case WrapShape::kTorus:
      return wrap_impl::OpenSimTorus(s.inner_radius, s.outer_radius, s.quadrant, p1, p2,
                                     single_wrap);
  }
  return {};
}

OsSegment AnySegment(const WrapSurface& s, const V3& p1, const V3& p2, WrapMode mode,
                     WrapMethod method, bool single_wrap) {
  return wrap_impl::SegmentInMode(OpenSimSegment(s, p1, p2, method, single_wrap), s, p1, p2, mode);
}

}  // namespace

OsSegment wrap_impl::SegmentInMode(OsSegment os, const WrapSurface& s, const V3& p1, const V3& p2,
                                   WrapMode mode) {
  if (os.has_path && (!os.r1.allFinite() || !os.r2.allFinite() || !std::isfinite(os.length))) {
    // Whatever NaN OpenSim's arithmetic reached (an end point on an ellipsoid, a plane through
    // a degenerate c1, ...): the segment does not wrap, and says why.
    os.has_path = false;
    os.code = 0;
    os.status |= kWrapDegenerate;
  }
  if (mode == WrapMode::kOpenSim) return os;
  return wrap_impl::ExactSegment(s, p1, p2, os);
}

WrapSegmentResult WrapSegment(const WrapSurface& surface, const Eigen::Vector3d& p1,
                              const Eigen::Vector3d& p2, WrapMode mode, WrapMethod method,
                              bool single_wrap) {
  const OsSegment w = AnySegment(surface, p1, p2, mode, method, single_wrap);
  WrapSegmentResult out;
  out.action = static_cast<WrapAction>(w.code);
  out.wraps = w.has_path && w.code >= 2 && w.r1.allFinite() && w.r2.allFinite();
  out.status = w.status;
  if (out.wraps) {
    out.r1 = w.r1;
    out.r2 = w.r2;
    out.arc_length = w.length;
    const double straight = (p2 - p1).norm();
    const double wrapped = (w.r1 - p1).norm() + w.length + (p2 - w.r2).norm();
    if (wrapped < straight * (1.0 - 1e-12)) out.status |= kWrapBelowStraightLine;
  }
  return out;
}

void ComputeWrappedPath(const WrapPathInput& input, WrapMode mode, WrappedPath& out) {
  using Element = WrappedPath::Element;
  const int n_points = static_cast<int>(input.points.size());
  const int n_wraps = static_cast<int>(input.wraps.size());
  if (static_cast<int>(input.active.size()) != n_points) {
    throw Error("ComputeWrappedPath: " + std::to_string(input.active.size()) +
                " active flags for " + std::to_string(n_points) + " points");
  }
  for (int k = 0; k < n_wraps; ++k) {
    const WrapPathWrap& w = input.wraps[k];
    if (w.first < 0 || w.last >= n_points || w.first > w.last) {
      throw Error("ComputeWrappedPath: wrap " + std::to_string(k) + " has the range [" +
                  std::to_string(w.first) + ", " + std::to_string(w.last) + "] for " +
                  std::to_string(n_points) + " points");
    }
  }
  out.length = 0.0;
  out.status = 0;
  out.passes = 0;
  out.point_pull.assign(n_points, V3::Zero());
  out.wraps.assign(n_wraps, WrappedPath::Wrap());
  std::vector<Element>& path = out.elements;
  path.clear();
  // GeometryPath::computePath: the active points in order.
  for (int i = 0; i < n_points; ++i) {
    if (input.active[i]) path.push_back({i, -1, 0, input.points[i]});
  }
  const bool single_wrap = n_wraps == 1;
  auto object_of = [&](int k) {
    return input.wraps[k].object >= 0 ? input.wraps[k].object : n_wraps + k;
  };
  // PathPoint::getWrapObject() equality: two wrap points of the same wrap object.
  auto same_object = [&](const Element& a, const Element& b) {
    return a.wrap >= 0 && b.wrap >= 0 && object_of(a.wrap) == object_of(b.wrap);
  };
  auto remove_wrap_points = [&](int k) {
    for (size_t j = 0; j < path.size(); ++j) {
      if (path[j].wrap == k && path[j].end == 0) {
        path.erase(path.begin() + static_cast<long>(j), path.begin() + static_cast<long>(j) + 2);
        return;
      }
    }
  };
  // OpenSim mode: the ground position of a wrap point is frozen the first time it is read in a
  // state. Point::getLocationInGround (OpenSim/Simulation/Model/Point.cpp) caches it at
  // Stage::Position, and PathWrapPoint::setLocation does not invalidate that cache; so once a
  // length is summed (calcLengthAfterPathComputation at the end of a pass) or compared
  // (calcPathLengthChange) with a wrap point, later passes move the point (its location, which
  // WrapObject::wrapPathSegment reads afresh) but every length, and the path GeometryPath
  // reports, keeps its first ground position, with the arc of the last pass. Only muscles with
  // several wraps run more than one pass. (Reproduces opensim-core's recorded lengths of
  // Rajagopal's med_gas_r to 2e-7 m where both of its cylinders engage: 5.6 mm off without.)
  const bool freeze = mode == WrapMode::kOpenSim;
  V3 frozen_small[32];
  char frozen_set_small[32] = {};
  std::vector<V3> frozen_large;
  std::vector<char> frozen_set_large;
  V3* frozen = frozen_small;
  char* frozen_set = frozen_set_small;
  if (n_wraps > 16) {
    frozen_large.resize(static_cast<size_t>(2 * n_wraps));
    frozen_set_large.assign(static_cast<size_t>(2 * n_wraps), 0);
    frozen = frozen_large.data();
    frozen_set = frozen_set_large.data();
  }
  // The ground position OpenSim reads for element e (a path point's is never stale).
  auto ground = [&](const Element& e) -> const V3& {
    if (!freeze || e.wrap < 0) return e.position;
    const int slot = 2 * e.wrap + e.end;
    if (!frozen_set[slot]) {
      frozen_set[slot] = 1;
      frozen[slot] = e.position;
    }
    return frozen[slot];
  };
  // calcLengthAfterPathComputation: straight distances, plus each wrap's arc between its two
  // points (the length PathWrapPoint 2 carries; PathWrapPoint 1 carries 0).
  auto path_length = [&]() {
    double length = 0.0;
    for (size_t j = 1; j < path.size(); ++j) {
      if (same_object(path[j - 1], path[j])) {
        if (path[j].end == 1) length += out.wraps[path[j].wrap].arc_length;
      } else {
        length += (ground(path[j]) - ground(path[j - 1])).norm();
      }
    }
    return length;
  };
  if (n_wraps > 0 && !path.empty()) {
    // The order of the wraps and each one's last wrapLine code: on the stack for up to 16 wraps
    // (the engine calls this at every posture and must not allocate), else on the heap.
    int order_small[16], result_small[16];
    std::vector<int> order_large, result_large;
    int* order = order_small;
    int* result = result_small;
    if (n_wraps > 16) {
      order_large.resize(static_cast<size_t>(n_wraps));
      result_large.resize(static_cast<size_t>(n_wraps));
      order = order_large.data();
      result = result_large.data();
    }
    for (int i = 0; i < n_wraps; ++i) {
      order[i] = i;
      result[i] = 0;
    }
    const bool exact = mode == WrapMode::kExact;
    const int max_passes = n_wraps < 2 ? 1 : exact ? kExactMaxPasses : kMaxPasses;
    const double pass_tolerance = exact ? kExactPassTolerance : kPassTolerance;
    double last_length = std::numeric_limits<double>::infinity();
    bool settled = n_wraps < 2;
    bool aborted = false;
    for (int kk = 0; kk < max_passes && !aborted; ++kk) {
      out.passes = kk + 1;
      for (int i = 0; i < n_wraps; ++i) {
        result[i] = 0;
        const int k = order[i];
        const WrapPathWrap& ws = input.wraps[k];
        WrappedPath::Wrap& state = out.wraps[k];
        remove_wrap_points(k);
        state.wrapped = false;
        if (!ws.active) continue;
        // The first and last active points of the range (indices of the path point list).
        int jfwd = ws.first;
        while (jfwd <= ws.last && !input.active[jfwd]) ++jfwd;
        int jrev = ws.last;
        while (jrev >= ws.first && !input.active[jrev]) --jrev;
        if (jfwd > ws.last || jrev < ws.first) {  // "return": this wrap and the rest stop
          state.status |= kWrapRangeEmpty;
          aborted = true;
          break;
        }
        int start = -1, end = -1;
        for (size_t j = 0; j < path.size(); ++j) {
          if (path[j].point == jfwd) start = static_cast<int>(j);
          if (path[j].point == jrev) end = static_cast<int>(j);
        }
        const Eigen::Isometry3d X_S_W = ws.X_W_S.inverse();
        bool have_best = false;
        OsSegment best;
        int best_end = -1;
        double min_change = std::numeric_limits<double>::infinity();
        for (int pt1 = start; pt1 < end; ++pt1) {
          const int pt2 = pt1 + 1;
          if (same_object(path[pt1], path[pt2])) continue;
          const V3 a = X_S_W * path[pt1].position;
          const V3 b = X_S_W * path[pt2].position;
          const OsSegment wr = AnySegment(ws.surface, a, b, mode, ws.method, single_wrap);
          result[i] = wr.code;
          if (wr.code == 3) {  // mandatoryWrap: the first such segment is the one
            best = wr;
            best_end = pt2;
            have_best = true;
            break;
          }
          if (wr.code == 2) {  // wrapped: keep the segment lengthened least (NaN never wins)
            // (calcPathLengthChange reads the end points' ground positions: ground())
            const V3& g1 = ground(path[pt1]);
            const V3& g2 = ground(path[pt2]);
            const double straight = (g2 - g1).norm();
            const double change = (ws.X_W_S * wr.r1 - g1).norm() + wr.length +
                                  (g2 - ws.X_W_S * wr.r2).norm() - straight;
            if (change < min_change) {
              best = wr;
              best_end = pt2;
              have_best = true;
              min_change = change;
            }
          }
        }
        state.action =
            have_best ? static_cast<WrapAction>(best.code) : static_cast<WrapAction>(result[i]);
        if (!have_best || !best.has_path || !best.r1.allFinite() || !best.r2.allFinite()) {
          continue;  // no wrap points: resetPreviousWrap
        }
        state.wrapped = true;
        state.r1_S = best.r1;
        state.r2_S = best.r2;
        state.r1 = ws.X_W_S * best.r1;
        state.r2 = ws.X_W_S * best.r2;
        state.arc_length = best.length;
        state.status = best.status;
        path.insert(path.begin() + best_end,
                    {Element{-1, k, 0, state.r1}, Element{-1, k, 1, state.r2}});
      }
      if (aborted) break;
      const double length = path_length();
      if (std::fabs(length - last_length) < pass_tolerance) {
        settled = true;
        break;
      }
      last_length = length;
      if (kk == 0 && n_wraps > 1 && result[0] == 0 && result[1] == 1) {
        // The first wrap did not wrap and the second had a point inside: swap them and retry
        // (and take wrap 0's points out of the path, as the original does).
        order[0] = 1;
        order[1] = 0;
        remove_wrap_points(0);
        out.wraps[0].wrapped = false;
      }
    }
    if (!settled && !aborted) out.status |= kWrapNotConverged;
    if (aborted) out.status |= kWrapRangeEmpty;
    // The path OpenSim reports (its length, its forces, its drawing): each wrap point where its
    // ground position was frozen, with the last pass's arc.
    for (Element& e : path) {
      if (e.wrap < 0 || !freeze) continue;
      e.position = ground(e);
      WrappedPath::Wrap& w = out.wraps[e.wrap];
      const Eigen::Isometry3d X_S_W = input.wraps[e.wrap].X_W_S.inverse();
      (e.end == 0 ? w.r1 : w.r2) = e.position;
      (e.end == 0 ? w.r1_S : w.r2_S) = X_S_W * e.position;
    }
  }
  // Length, pulls, and the straight-line check of every wrap.
  out.length = path_length();
  for (size_t j = 1; j < path.size(); ++j) {
    const Element& a = path[j - 1];
    const Element& b = path[j];
    if (same_object(a, b)) continue;
    const V3 d = b.position - a.position;
    const double l = d.norm();
    if (!(l >= kMinSegment)) {
      out.status |= kWrapDegenerate;
      continue;
    }
    const V3 u = d / l;
    auto pull = [&](const Element& e) -> V3& {
      if (e.point >= 0) return out.point_pull[e.point];
      return e.end == 0 ? out.wraps[e.wrap].pull_r1 : out.wraps[e.wrap].pull_r2;
    };
    pull(a) -= u;
    pull(b) += u;
  }
  for (size_t j = 1; j + 2 < path.size(); ++j) {
    if (path[j].wrap < 0 || path[j].end != 0 || path[j + 1].wrap != path[j].wrap) continue;
    WrappedPath::Wrap& w = out.wraps[path[j].wrap];
    const V3& before = path[j - 1].position;
    const V3& after = path[j + 2].position;
    const double wrapped = (w.r1 - before).norm() + w.arc_length + (after - w.r2).norm();
    if (wrapped < (after - before).norm() * (1.0 - 1e-12)) w.status |= kWrapBelowStraightLine;
  }
  for (const WrappedPath::Wrap& w : out.wraps) {
    if (w.wrapped || (w.status & kWrapRangeEmpty)) out.status |= w.status;
  }
}

}  // namespace isowrench
