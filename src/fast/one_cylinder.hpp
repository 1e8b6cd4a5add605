#pragma once
// Private: the path stage of a muscle over one cylinder with fixed points (FastMuscle::
// one_cylinder), the kernel's kWrap step (src/fast/kernel.hpp), inline so that the evaluation
// compiles it and the cylinder (wrap/cylinder_single.hpp) into its kernel
// (docs/performance.md "Wrapping muscles").

#include <cmath>
#include <limits>

#include "fast/fast_impl.hpp"
#include "fast/simd.hpp"
#include "fast/vec3.hpp"
#include "model/model_impl.hpp"
#include "wrap/cylinder_single.hpp"

namespace isowrench {

/// WrappedPathPulls's result for a muscle over one cylinder with fixed points, without its
/// general path: GeometryPath::applyWrapObjects for one wrap over points that are all active
/// (as ComputeWrappedPath: the segments of the range in order, the first mandatory wrap, else
/// the one that lengthens its segment least, a NaN change never winning), each segment through
/// CylinderSingle (and the exact path in kExact, SegmentInMode); the length and the
/// pulls of the points and of the two tangent points written directly (and their sum and the
/// sum of their moments about the world origin in slot_pull, slot_moment, which the kernel's
/// sweep adds at the cylinder's frame instead of visiting the slots); nothing allocated. On
/// entry the first slot holds the origin of the cylinder's frame S and ws.point_rotation there
/// the rotation of its link's frame; on return the two slots hold r1 and r2 (0 when it does not
/// wrap, with zero pulls). Returns false when two consecutive points coincide (as
/// WrappedPathPulls). W: a workspace (SmallWorkspace, LargeWorkspace, Data::Impl).
template <class W>
ISOWRENCH_INLINE bool OneCylinderPathPulls(const FastMuscle& muscle, W& ws, double* length,
                                           Vec3<double>& slot_pull, Vec3<double>& slot_moment) {
  using V = Vec3<double>;
  const FastWrap& f = muscle.wraps[0];
  const WrapPathWrap& wrap = f.wrap;
  const int n = muscle.path_points;
  const int slot = f.slot;
  V* const p = ws.points.data();
  V* const g = ws.pulls.data();
  // X_W_S: R = R_W_frame FastWrap::rotation (columns), o = the first slot's position.
  V R[3], Rt[3];
  ISOWRENCH_UNROLL
  for (int c = 0; c < 3; ++c) {
    R[c] = Transform(ws.point_rotation[slot].data(), f.rotation.data() + 3 * c);
  }
  Transpose(R, Rt);
  const V o = p[slot];
  auto to_S = [&](const V& x) ISOWRENCH_LAMBDA_INLINE { return Rotate(Rt, x - o); };  // R^T (x - o)
  auto to_W = [&](double x, double y, double z) ISOWRENCH_LAMBDA_INLINE {
    return Rotate(R, V{x, y, z, 0.0}) + o;
  };
  auto norm = [](const V& x) ISOWRENCH_LAMBDA_INLINE {
    double s;
    Dot(x, x, s);
    return std::sqrt(s);
  };
  bool wrapped = false;
  int wrapped_end = 0;  // the wrap sits between points wrapped_end - 1 and wrapped_end
  V r1 = Zero3<double>(), r2 = Zero3<double>();
  double arc = 0.0;
  if (wrap.first < wrap.last) {
    const WrapSurface& s = wrap.surface;
    const bool several = wrap.last - wrap.first > 1;
    double min_change = std::numeric_limits<double>::infinity();
    V b = to_S(p[wrap.first]);
    for (int pt2 = wrap.first + 1; pt2 <= wrap.last; ++pt2) {
      const V a = b;
      b = to_S(p[pt2]);
      wrap_impl::CylinderSingleResult c = wrap_impl::CylinderSingle(
          s.radius, s.length, s.quadrant.axis, s.quadrant.sign, a[0], a[1], a[2], b[0], b[1], b[2]);
      bool has_path = c.wraps;  // (and r1, r2 finite)
      // ComputeWrappedPath's NaN check and exact path (SegmentInMode), called only when it has
      // something to do: in kExact, or when a number is not finite (tested through their sum;
      // SegmentInMode tests them one by one).
      if (muscle.wrap_mode != WrapMode::kOpenSim ||
          (c.wraps && !std::isfinite(c.r1x + c.r1y + c.r1z + c.r2x + c.r2y + c.r2z + c.length))) {
        const wrap_impl::OsSegment wr = wrap_impl::SegmentInMode(
            wrap_impl::ToOsSegment(c), s, Eigen::Vector3d(a[0], a[1], a[2]),
            Eigen::Vector3d(b[0], b[1], b[2]), muscle.wrap_mode);
        c.code = wr.code;
        c.r1x = wr.r1.x();
        c.r1y = wr.r1.y();
        c.r1z = wr.r1.z();
        c.r2x = wr.r2.x();
        c.r2y = wr.r2.y();
        c.r2z = wr.r2.z();
        c.length = wr.length;
        has_path = wr.has_path && wr.r1.allFinite() && wr.r2.allFinite();
      }
      if (c.code != 3 && c.code != 2) continue;
      const V w1 = to_W(c.r1x, c.r1y, c.r1z), w2 = to_W(c.r2x, c.r2y, c.r2z);
      if (c.code == 2 && several) {  // (one segment: the change is finite as r1, r2 and L are)
        const double change =
            norm(w1 - p[pt2 - 1]) + c.length + norm(p[pt2] - w2) - norm(p[pt2] - p[pt2 - 1]);
        if (!(change < min_change)) continue;
        min_change = change;
      }
      wrapped = has_path;
      wrapped_end = pt2;
      r1 = w1;
      r2 = w2;
      arc = c.length;
      if (c.code == 3) break;
    }
  }
  // The length (calcLengthAfterPathComputation) and the pulls: each straight segment a -> b of
  // length l >= kFastMinSegmentLength adds -u at a and +u at b (u = (b - a) / l); the arc pulls
  // nothing. Two consecutive path points that coincide: no path (as WrappedPathPulls).
  double total = 0.0;
  V before = Zero3<double>();  // u of the segment arriving at point i - 1
  auto tangent = [&](const V& a, const V& b) ISOWRENCH_LAMBDA_INLINE {  // u (0 when too short)
    const V d = b - a;
    const double l = norm(d);
    total += l;
    return l >= kFastMinSegmentLength ? d * (1.0 / l) : Zero3<double>();
  };
  g[slot] = g[slot + 1] = Zero3<double>();
  slot_pull = slot_moment = Zero3<double>();
  for (int i = 1; i < n; ++i) {
    const V d = p[i] - p[i - 1];
    const double l = norm(d);
    if (!(l >= kFastMinSegmentLength)) {
      *length = 0.0;
      return false;
    }
    if (wrapped && i == wrapped_end) {  // p[i - 1] -> r1 (u1), the arc, r2 -> p[i] (u2)
      const V u1 = tangent(p[i - 1], r1);
      total += arc;
      const V u2 = tangent(r2, p[i]);
      g[i - 1] = before - u1;
      g[slot] = u1;
      g[slot + 1] = -u2;
      slot_pull = u1 - u2;
      slot_moment = Cross(r1, u1) - Cross(r2, u2);
      before = u2;
      continue;
    }
    const V u = d * (1.0 / l);
    total += l;
    g[i - 1] = before - u;
    before = u;
  }
  if (n > 0) g[n - 1] = before;
  p[slot] = r1;
  p[slot + 1] = r2;
  *length = total;
  return true;
}

}  // namespace isowrench
