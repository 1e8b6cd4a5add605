#pragma once
// Private: OpenSim's smooth segmented quintic Bezier curves (Common/SmoothSegmentedFunction,
// SmoothSegmentedFunctionFactory, SegmentedQuinticBezierToolkit) for the Millard2012 muscle
// curves, with the coefficients precomputed so that an evaluation allocates nothing.
//
// A curve is a chain of quintic Bezier segments (x(u), y(u)), u in [0, 1], each monotone in x,
// joined end to end over [x0, x1], and the straight lines y0 + slope0 (x - x0) left of x0 and
// y1 + slope1 (x - x1) right of x1. y(x) needs u(x): OpenSim fits a cubic spline of u(x) per
// segment and refines it by Newton's method to |x(u) - x| <= 100 eps (calcU); here a quintic
// Hermite guess from u, du/dx and d2u/dx2 at 129 exact samples per segment (OpenSim's default
// curves: the first Newton step at most 6.6e-9 on the damped model's active curve, floor 0, and
// 1.7e-10 on the others; tests/muscle/curve_test.cpp) is refined by one Newton step to machine
// precision (more steps only where that step exceeds 1e-8: none on the default curves; with 65
// samples, up to 3.6e-7), so the values are those of the exact curve.
//
// Three evaluations share that u(x), so they give the same value to the last bit: Evaluate
// (value and exact slope), Value (value only: the rigid tendon's force) and SolveEvaluate (value
// and a slope from dx/du before the Newton step, ~1e-9 relative: the equilibrium iteration's
// Newton slope, one polynomial fewer).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "isowrench/muscle.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace isowrench::muscle {

#if defined(__GNUC__)
#define ISOWRENCH_CURVE_INLINE inline __attribute__((always_inline))
#else
#define ISOWRENCH_CURVE_INLINE inline
#endif
#if defined(__GNUC__)
#define ISOWRENCH_CURVE_LAMBDA_INLINE __attribute__((always_inline))
#else
#define ISOWRENCH_CURVE_LAMBDA_INLINE
#endif

/// Four doubles / four 64-bit lane masks (GCC/Clang vector extensions): the batch force stage's
/// lanes (MuscleForceModel::Tension4).
typedef double LaneDoubles __attribute__((vector_size(32)));
typedef long long LaneMasks __attribute__((vector_size(32)));

// The AVX2 forms of the lanes (kAvx2 below: GCC builtins, expanded in the caller's target
// after inlining; MuscleForceModel::Tension4's avx2 version instantiates them, the baseline
// version the portable forms).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define ISOWRENCH_CURVE_AVX2 1
#include <immintrin.h>  // (declares the AVX2 builtins)
// (-Wpsabi: the builtins' 32-byte results, in code only ever inlined into AVX2 functions;
// popped at the end of this header)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

/// Bit l set where lane l of `mask` is set (all bits), l = 0..3 (kAvx2: one vmovmskpd).
template <bool kAvx2 = false>
ISOWRENCH_CURVE_INLINE unsigned LaneBits(const LaneMasks& mask) {
#if defined(ISOWRENCH_CURVE_AVX2)
  if constexpr (kAvx2) return static_cast<unsigned>(__builtin_ia32_movmskpd256((LaneDoubles)mask));
#endif
#if defined(__SSE2__)
  const LaneDoubles m = (LaneDoubles)mask;
  const int lo = _mm_movemask_pd((__m128d)__builtin_shufflevector(m, m, 0, 1));
  const int hi = _mm_movemask_pd((__m128d)__builtin_shufflevector(m, m, 2, 3));
  return static_cast<unsigned>(lo | (hi << 2));
#else
  return static_cast<unsigned>((mask[0] & 1) | (mask[1] & 2) | (mask[2] & 4) | (mask[3] & 8));
#endif
}

/// out = ~(a <= b), ~(a >= b), ~(a > b) lane by lane (all true for NaN); kAvx2: one vcmppd.
template <bool kAvx2>
ISOWRENCH_CURVE_INLINE void LaneNotLessEqual(const LaneDoubles& a, const LaneDoubles& b,
                                             LaneMasks& out) {
#if defined(ISOWRENCH_CURVE_AVX2)
  if constexpr (kAvx2) {
    out = (LaneMasks)__builtin_ia32_cmppd256(a, b, 0x16);  // (_CMP_NLE_UQ)
    return;
  }
#endif
  out = ~(LaneMasks)(a <= b);
}
template <bool kAvx2>
ISOWRENCH_CURVE_INLINE void LaneNotGreaterEqual(const LaneDoubles& a, const LaneDoubles& b,
                                                LaneMasks& out) {
#if defined(ISOWRENCH_CURVE_AVX2)
  if constexpr (kAvx2) {
    out = (LaneMasks)__builtin_ia32_cmppd256(a, b, 0x19);  // (_CMP_NGE_UQ)
    return;
  }
#endif
  out = ~(LaneMasks)(a >= b);
}
template <bool kAvx2>
ISOWRENCH_CURVE_INLINE void LaneNotGreater(const LaneDoubles& a, const LaneDoubles& b,
                                           LaneMasks& out) {
#if defined(ISOWRENCH_CURVE_AVX2)
  if constexpr (kAvx2) {
    out = (LaneMasks)__builtin_ia32_cmppd256(a, b, 0x1a);  // (_CMP_NGT_UQ)
    return;
  }
#endif
  out = ~(LaneMasks)(a > b);
}

#if defined(ISOWRENCH_CURVE_AVX2)
/// AVX2 only (vgatherqpd): out[l] = base[index[l]].
ISOWRENCH_CURVE_INLINE void LaneGather(const double* base, const LaneMasks& index,
                                       LaneDoubles& out) {
  out = __builtin_ia32_gatherdiv4df(LaneDoubles{0.0, 0.0, 0.0, 0.0}, base, index,
                                    (LaneDoubles)(LaneMasks{-1, -1, -1, -1}), 8);
}
#endif

/// Control points of one quintic Bezier segment (Bernstein basis).
struct ControlPoints {
  std::array<double, 6> x{}, y{};
};

/// SegmentedQuinticBezierToolkit::calcQuinticBezierCornerControlPoints: the C-shaped corner
/// from (x0, y0) with slope dydx0 to (x1, y1) with slope dydx1, `curviness` in [0, 1] (already
/// scaled by SmoothSegmentedFunctionFactory::scaleCurviness). Returns false (OpenSim throws)
/// when the two tangent lines do not make a C-shaped corner.
bool CornerControlPoints(double x0, double y0, double dydx0, double x1, double y1, double dydx1,
                         double curviness, ControlPoints* out);

/// Bernstein-form value of a quintic at u (de Casteljau): an independent evaluation for tests.
double BezierValue(const std::array<double, 6>& points, double u);

class SmoothCurve {
 public:
  SmoothCurve() = default;
  /// Segments joined end to end; x0 = first segment's first x, x1 = last segment's last x.
  SmoothCurve(const ControlPoints* segments, int count, double y0, double y1, double slope0,
              double slope1);

  /// Value and slope at x (linear extrapolation outside [x0, x1]; NaN for NaN).
  CurvePoint Evaluate(double x) const {
    if (!(x >= x0_)) return {y0_ + slope0_ * (x - x0_), slope0_};
    if (x > x1_) return {y1_ + slope1_ * (x - x1_), slope1_};
    const Segment& g = Find(x);
    double dxdu;  // (U sets it)
    const double u = U(g, x, &dxdu);
    // calcQuinticBezierCurveDerivDYDX: dy/dx = (dy/du) / (dx/du), dx/du at the solved u.
    dxdu = Slope(g.dx, u);
    return {Poly(g.y, u), dxdu > 0.0 ? Slope(g.dy, u) / dxdu : 0.0};
  }
  /// Evaluate(x).value, without the slope.
  ISOWRENCH_CURVE_INLINE double Value(double x) const {
    if (!(x >= x0_)) return y0_ + slope0_ * (x - x0_);
    if (x > x1_) return y1_ + slope1_ * (x - x1_);
    const Segment& g = Find(x);
    double dxdu;  // (U sets it)
    return Poly(g.y, U(g, x, &dxdu));
  }
  /// Evaluate(x).value, and the slope with dx/du taken before the last Newton step of u(x)
  /// (relative error ~ |x''/x'| |du|, about 1e-10): for Newton iterations on the curve, where
  /// the slope only steers.
  CurvePoint SolveEvaluate(double x) const {
    if (!(x >= x0_)) return {y0_ + slope0_ * (x - x0_), slope0_};
    if (x > x1_) return {y1_ + slope1_ * (x - x1_), slope1_};
    const Segment& g = Find(x);
    double dxdu;  // (U sets it)
    const double u = U(g, x, &dxdu);
    return {Poly(g.y, u), dxdu > 0.0 ? Slope(g.dy, u) / dxdu : 0.0};
  }

  /// Four arguments at once: value[l] = Value(x[l]) and, with kSlope, slope[l] =
  /// SolveEvaluate(x[l]).slope, bit for bit: per lane the same operations in the same order
  /// (the caller compiles them without contracting a * b + c into a fused multiply-add:
  /// muscle_force.cpp). The segment and the guess interval are looked up per lane; a lane whose
  /// guess needs more than one Newton step (Converge) runs the scalar evaluation. kAvx2 (only
  /// where ISOWRENCH_CURVE_AVX2 is defined, in a function compiled for AVX2): the lanes'
  /// segments, guess intervals and coefficients by vector indices and AVX2 gathers from the
  /// segment table (the same numbers, so the same bits).
  template <bool kSlope, bool kAvx2 = false>
  void Lanes(const LaneDoubles& x, LaneDoubles& value, LaneDoubles& slope) const;

  /// SolveEvaluate(x) (`slope` false: Value(x) and slope 0), out of line: the lanes' fallback.
  CurvePoint ScalarLane(double x, bool slope) const;
  /// ScalarLane for the lanes l with bit l of `lanes` set: value[l] and (kSlope) slope[l].
  template <bool kSlope>
  ISOWRENCH_CURVE_INLINE void ScalarLanes(const LaneDoubles& x, unsigned lanes, LaneDoubles& value,
                                          LaneDoubles& slope) const {
    for (int l = 0; l < 4; ++l) {
      if (!(lanes & (1u << l))) continue;
      const CurvePoint p = ScalarLane(x[l], kSlope);
      value[l] = p.value;
      if constexpr (kSlope) slope[l] = p.slope;
    }
  }

  /// |du| of the first Newton step of u(x) from the guess table at x in [x0, x1]: the table's
  /// error in u, to first order. One step suffices where it is at most 1e-8 (else the
  /// evaluation iterates on, and the lanes fall back to ScalarLane).
  double FirstNewtonStep(double x) const {
    const Segment& g = Find(x);
    const double u = Guess(g, x);
    return std::abs((Poly(g.x, u) - x) / Slope(g.dx, u));
  }

  int segment_count() const { return count_; }
  const ControlPoints& control_points(int i) const { return control_[i]; }
  double x0() const { return x0_; }
  double x1() const { return x1_; }

 private:
  static constexpr int kMaxSegments = 5;
  static constexpr int kGuessIntervals = 128;
  struct Segment {
    double x_begin = 0.0, x_end = 0.0, inv_step = 0.0;
    std::array<double, 6> x{}, y{};    // power-basis coefficients of x(u), y(u)
    std::array<double, 5> dx{}, dy{};  // of dx/du, dy/du (k a_k)
    // The quintic Hermite guess of u on interval k as a quintic in r = t - k:
    // guess[6k + i] r^i; interval kGuessIntervals (t rounded to it at x = x_end) is u's
    // Taylor polynomial there.
    std::array<double, 6 * (kGuessIntervals + 1)> guess{};
    // For the lanes: x_begin, inv_step, x, dx, y, dy (kLane* below) packed (a 4 x 4 transpose
    // per 4 entries gathers them for four lanes in different segments) and splatted (four lanes
    // in this segment read them as whole vectors).
    alignas(32) std::array<double, 24> packed{};
    std::array<LaneDoubles, 24> splat{};
  };
  static constexpr int kLaneBegin = 0, kLaneInvStep = 1, kLaneX = 2, kLaneDx = 8, kLaneY = 13,
                       kLaneDy = 19;

  // Lanes<kSlope, true>.
  template <bool kSlope>
  void GatherLanes(const LaneDoubles& x, LaneDoubles& value, LaneDoubles& slope) const;
  // out[k] = (k + 1) a[k + 1], k < 5: the derivative's coefficients, as the table's products
  // (the factors from multiples_: memory operands, not constants loaded per use).
  ISOWRENCH_CURVE_INLINE void Multiples(const LaneDoubles* a, LaneDoubles* out) const {
    out[0] = a[1];
    for (int k = 1; k < 5; ++k) out[k] = a[k + 1] * multiples_[static_cast<std::size_t>(k - 1)];
  }

  static double Poly(const std::array<double, 6>& a, double u) {
    return ((((a[5] * u + a[4]) * u + a[3]) * u + a[2]) * u + a[1]) * u + a[0];
  }
  static double Slope(const std::array<double, 5>& b, double u) {
    return (((b[4] * u + b[3]) * u + b[2]) * u + b[1]) * u + b[0];
  }
  // calcIndex: the segment with x_begin <= x < x_end (the last one for x = x1): the number
  // of inner segment ends at or before x, without a loop (ends_ past the last are +inf).
  const Segment& Find(double x) const {
    int s = x >= ends_[0];
    if (count_ > 2) s += (x >= ends_[1]) + (x >= ends_[2]) + (x >= ends_[3]);
    return segments_[static_cast<std::size_t>(s)];
  }
  // calcU: u in [0, 1] with x(u) = x on segment g (x in [x_begin, x_end]); *dxdu: dx/du at
  // the u before the last Newton step.
  // The guess table's u at x on segment g.
  static double Guess(const Segment& g, double x) {
    const double t = (x - g.x_begin) * g.inv_step;  // in [0, kGuessIntervals (1 + 2 eps)]
    const int k = static_cast<int>(t);
    const double r = t - k;
    const double* c = &g.guess[6 * static_cast<std::size_t>(k)];
    // (No clamp to [0, 1]: the guess is within ~1e-8 of u in [0, 1], and the polynomials are
    // as good just outside; at a knot it is the knot's exact u, 0 at a segment's start.)
    return ((((c[5] * r + c[4]) * r + c[3]) * r + c[2]) * r + c[1]) * r + c[0];
  }
  double U(const Segment& g, double x, double* dxdu) const {
    const double u = Guess(g, x);
    const double d = Slope(g.dx, u);
    const double du = (Poly(g.x, u) - x) / d;
    // Newton converges quadratically: after a step du the error in u is about
    // |x''/(2 x')| du^2, below 1e-15 once |du| <= 1e-8 (x''/x' is O(1) to O(10) on these
    // corners), so that step is the last. (d > 0 on a corner segment; not: Converge.)
    if (!(std::abs(du) <= 1e-8)) return Converge(g, x, u, dxdu);
    *dxdu = d;
    return std::min(u - du, 1.0);  // (x = x1: exactly the curve's end)
  }
  // Newton's method from u until a step is at most 1e-8 (a guess too far for one step).
  double Converge(const Segment& g, double x, double u, double* dxdu) const;

  std::vector<Segment> segments_;  // (sized once: an evaluation allocates nothing)
  // The gather lanes' numbers splatted (memory operands, not a broadcast per use).
  struct LaneConstants {
    LaneDoubles x0{}, x1{}, ends[kMaxSegments - 1]{}, y0{}, slope0{}, y1{}, slope1{};
    LaneDoubles step_limit{}, one{};  // 1e-8 (U's one-step bound), 1
    LaneMasks magnitude{};            // all bits of a double but the sign
  };
  LaneConstants lane_;
  // 2, 3, 4, 5 in every lane (Multiples).
  std::array<LaneDoubles, 4> multiples_ = {
      LaneDoubles{2.0, 2.0, 2.0, 2.0}, LaneDoubles{3.0, 3.0, 3.0, 3.0},
      LaneDoubles{4.0, 4.0, 4.0, 4.0}, LaneDoubles{5.0, 5.0, 5.0, 5.0}};
  // x_end of segments 0 .. count - 2, then +inf.
  std::array<double, kMaxSegments - 1> ends_{};
  std::array<ControlPoints, kMaxSegments> control_{};
  int count_ = 0;
  double x0_ = 0.0, x1_ = 0.0, y0_ = 0.0, y1_ = 0.0, slope0_ = 0.0, slope1_ = 0.0;
};

#if defined(__GNUC__) && !defined(__clang__)
#define ISOWRENCH_CURVE_UNROLL _Pragma("GCC unroll 8")
#else
#define ISOWRENCH_CURVE_UNROLL
#endif

// out[i][l] = p_l[i], i < 4: four doubles from each of four addresses, transposed.
ISOWRENCH_CURVE_INLINE void LaneTranspose(const double* p0, const double* p1, const double* p2,
                                          const double* p3, LaneDoubles* out) {
  using V = LaneDoubles;
  V a0, a1, a2, a3;
  std::memcpy(&a0, p0, sizeof a0);
  std::memcpy(&a1, p1, sizeof a1);
  std::memcpy(&a2, p2, sizeof a2);
  std::memcpy(&a3, p3, sizeof a3);
  const V t0 = __builtin_shufflevector(a0, a1, 0, 4, 2, 6);
  const V t1 = __builtin_shufflevector(a0, a1, 1, 5, 3, 7);
  const V t2 = __builtin_shufflevector(a2, a3, 0, 4, 2, 6);
  const V t3 = __builtin_shufflevector(a2, a3, 1, 5, 3, 7);
  out[0] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  out[1] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  out[2] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  out[3] = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
}

template <bool kSlope, bool kAvx2>
ISOWRENCH_CURVE_INLINE void SmoothCurve::Lanes(const LaneDoubles& x, LaneDoubles& value,
                                               LaneDoubles& slope) const {
  using V = LaneDoubles;
  using VI = LaneMasks;
#define ISOWRENCH_CURVE_SPLAT(v) (V{(v), (v), (v), (v)})
#if defined(ISOWRENCH_CURVE_AVX2)
  if constexpr (kAvx2) {
    GatherLanes<kSlope>(x, value, slope);
    return;
  }
#endif
  const V x0 = ISOWRENCH_CURVE_SPLAT(x0_), x1 = ISOWRENCH_CURVE_SPLAT(x1_);
  const VI below = ~(VI)(x >= x0);  // (NaN too, as Value's !(x >= x0_))
  const VI above = (VI)(x > x1) & ~below;
  const VI inside = ~(below | above);
  // Outside [x0, x1]: the lines (x - x0 of a NaN x is NaN, as Value's).
  const V low = ISOWRENCH_CURVE_SPLAT(y0_) + ISOWRENCH_CURVE_SPLAT(slope0_) * (x - x0);
  const V high = ISOWRENCH_CURVE_SPLAT(y1_) + ISOWRENCH_CURVE_SPLAT(slope1_) * (x - x1);
  const unsigned inside_bits = LaneBits(inside);
  if (inside_bits == 0) {  // (e.g. the passive curve below its slack length)
    value = below ? low : high;
    if constexpr (kSlope) {
      slope = below ? ISOWRENCH_CURVE_SPLAT(slope0_) : ISOWRENCH_CURVE_SPLAT(slope1_);
    }
    return;
  }
  // The other lanes look up the first inside lane's x (they stay in the table and do not
  // split the lanes' segments).
  const double fill = x[__builtin_ctz(inside_bits)];
  const V xs = inside ? x : ISOWRENCH_CURVE_SPLAT(fill);
  // Find, per lane: the inner segment ends at or before x.
  VI seg = (VI)(xs >= ISOWRENCH_CURVE_SPLAT(ends_[0]));
  if (count_ > 2) {
    seg += (VI)(xs >= ISOWRENCH_CURVE_SPLAT(ends_[1])) +
           (VI)(xs >= ISOWRENCH_CURVE_SPLAT(ends_[2])) +
           (VI)(xs >= ISOWRENCH_CURVE_SPLAT(ends_[3]));
  }
  const Segment* g[4];
  ISOWRENCH_CURVE_UNROLL
  for (int l = 0; l < 4; ++l) g[l] = &segments_[static_cast<std::size_t>(-seg[l])];
  // The segments' coefficients as vectors: one segment's splatted ones, or four gathered.
  V gathered[24];
  const V* c = g[0]->splat.data();
  if (!(g[1] == g[0] && g[2] == g[0] && g[3] == g[0])) {
    ISOWRENCH_CURVE_UNROLL
    for (int q = 0; q < 24; q += 4) {
      LaneTranspose(g[0]->packed.data() + q, g[1]->packed.data() + q, g[2]->packed.data() + q,
                    g[3]->packed.data() + q, gathered + q);
    }
    c = gathered;
  }
  // U: the guess interval k = (int) t and r = t - k per lane, the guess's six coefficients.
  const V t = (xs - c[kLaneBegin]) * c[kLaneInvStep];
  const double* guess[4];
  V r = ISOWRENCH_CURVE_SPLAT(0.0);
  ISOWRENCH_CURVE_UNROLL
  for (int l = 0; l < 4; ++l) {
    const int k = static_cast<int>(t[l]);
    r[l] = t[l] - k;
    guess[l] = &g[l]->guess[6 * static_cast<std::size_t>(k)];
  }
  V cg[4];
  LaneTranspose(guess[0], guess[1], guess[2], guess[3], cg);
  const V c4 = V{guess[0][4], guess[1][4], guess[2][4], guess[3][4]};
  const V c5 = V{guess[0][5], guess[1][5], guess[2][5], guess[3][5]};
  const V u = ((((c5 * r + c4) * r + cg[3]) * r + cg[2]) * r + cg[1]) * r + cg[0];
  const V* cx = c + kLaneX;
  const V* cdx = c + kLaneDx;
  const V* cy = c + kLaneY;
  const V d = (((cdx[4] * u + cdx[3]) * u + cdx[2]) * u + cdx[1]) * u + cdx[0];
  const V du = (((((cx[5] * u + cx[4]) * u + cx[3]) * u + cx[2]) * u + cx[1]) * u + cx[0] - xs) / d;
  const V v = u - du;
  const V one = ISOWRENCH_CURVE_SPLAT(1.0);
  const V un = (one < v) ? one : v;  // std::min(u - du, 1.0)
  V y = ((((cy[5] * un + cy[4]) * un + cy[3]) * un + cy[2]) * un + cy[1]) * un + cy[0];
  V s = ISOWRENCH_CURVE_SPLAT(0.0);
  if constexpr (kSlope) {
    const V* cdy = c + kLaneDy;
    const V dy = (((cdy[4] * un + cdy[3]) * un + cdy[2]) * un + cdy[1]) * un + cdy[0];
    s = (d > ISOWRENCH_CURVE_SPLAT(0.0)) ? dy / d : ISOWRENCH_CURVE_SPLAT(0.0);
  }
  y = below ? low : y;
  y = above ? high : y;
  if constexpr (kSlope) {
    s = below ? ISOWRENCH_CURVE_SPLAT(slope0_) : s;
    s = above ? ISOWRENCH_CURVE_SPLAT(slope1_) : s;
  }
  // Lanes inside whose Newton step exceeds 1e-8 (or is not a number): the scalar evaluation.
  const VI far =
      inside & ~(VI)(((V)((VI)du & 0x7fffffffffffffffLL)) <= ISOWRENCH_CURVE_SPLAT(1e-8));
  if (const unsigned far_bits = LaneBits(far); far_bits != 0)
    ScalarLanes<kSlope>(x, far_bits, y, s);
  value = y;
  if constexpr (kSlope) slope = s;
#undef ISOWRENCH_CURVE_SPLAT
}

#if defined(ISOWRENCH_CURVE_AVX2)
template <bool kSlope>
ISOWRENCH_CURVE_INLINE void SmoothCurve::GatherLanes(const LaneDoubles& x, LaneDoubles& value,
                                                     LaneDoubles& slope) const {
  using V = LaneDoubles;
  using VI = LaneMasks;
#define ISOWRENCH_CURVE_SPLAT(v) (V{(v), (v), (v), (v)})
  const V x0 = lane_.x0, x1 = lane_.x1;
  VI below;
  LaneNotGreaterEqual<true>(x, x0, below);  // (NaN too, as Value's !(x >= x0_))
  const VI above = (VI)(x > x1);            // (x1 > x0: not below)
  const unsigned below_bits = LaneBits<true>(below), above_bits = LaneBits<true>(above);
  const unsigned outside_bits = below_bits | above_bits;
  if (outside_bits == 0xf) {  // (e.g. the passive curve below its slack length)
    // Outside [x0, x1]: the lines (x - x0 of a NaN x is NaN, as Value's).
    value = __builtin_ia32_blendvpd256(lane_.y1 + lane_.slope1 * (x - x1),
                                       lane_.y0 + lane_.slope0 * (x - x0), (V)below);
    if constexpr (kSlope) {
      slope = __builtin_ia32_blendvpd256(lane_.slope1, lane_.slope0, (V)below);
    }
    return;
  }
  // (selects by vblendvpd: below, above are compare masks GCC cannot see through the builtin)
  // The lanes outside look up x clamped to [x0, x1] (NaN: x0), a valid segment and interval.
  V xs = (x > x0) ? x : x0;
  xs = (xs < x1) ? xs : x1;
  // Find, per lane: minus the number of inner segment ends at or before x; times minus the
  // segment stride (vpmuldq: the low 32 bits), the segment's offset in doubles.
  // (xs >= end by vcmppd GE with the splatted end as its memory operand: xs is not NaN)
  VI minus_segment = (VI)__builtin_ia32_cmppd256(xs, lane_.ends[0], 0x1d);  // (_CMP_GE_OQ)
  if (count_ > 2) {
    minus_segment += (VI)__builtin_ia32_cmppd256(xs, lane_.ends[1], 0x1d) +
                     (VI)__builtin_ia32_cmppd256(xs, lane_.ends[2], 0x1d) +
                     (VI)__builtin_ia32_cmppd256(xs, lane_.ends[3], 0x1d);
  }
  constexpr long long kStride = static_cast<long long>(sizeof(Segment) / sizeof(double));
  static_assert(sizeof(Segment) % sizeof(double) == 0, "segments in whole doubles");
  typedef int Ints8 __attribute__((vector_size(32)));
  typedef int Ints4 __attribute__((vector_size(16)));
  const VI offset = __builtin_ia32_pmuldq256((Ints8)minus_segment,
                                             (Ints8)(VI{-kStride, -kStride, -kStride, -kStride}));
  // The curve's polynomials on the lanes: the coefficients gathered per lane, or (kShared,
  // a two-segment curve whose lanes are all in segment `shared`) read once for all lanes.
  V y, s = ISOWRENCH_CURVE_SPLAT(0.0), du;
  auto evaluate = [&](auto shared_tag, int shared) ISOWRENCH_CURVE_LAMBDA_INLINE {
    constexpr bool kShared = decltype(shared_tag)::value;
    const Segment& s0 = segments_[static_cast<std::size_t>(shared)];
    auto coefficient = [&](int i, V& out) ISOWRENCH_CURVE_LAMBDA_INLINE {
      if constexpr (kShared) {
        out = s0.splat[static_cast<std::size_t>(i)];  // (whole vectors: memory operands)
      } else {
        LaneGather(s0.packed.data() + i, offset, out);
      }
    };
    // U: the guess interval k = (int) t and r = t - k per lane, the guess's six coefficients.
    // (kShared: the lanes outside the curve look up the segment's start)
    const V xq = kShared ? __builtin_ia32_blendvpd256(xs, ISOWRENCH_CURVE_SPLAT(s0.x_begin),
                                                      (V)(below | above))
                         : xs;
    V begin, inv_step;
    coefficient(kLaneBegin, begin);
    coefficient(kLaneInvStep, inv_step);
    const V t = (xq - begin) * inv_step;
    const Ints4 k = __builtin_convertvector(t, Ints4);  // (vcvttpd2dq: truncation, as (int) t)
    // (vcvtdq2pd, vpmovsxdq: __builtin_convertvector takes two halves for each)
    const V r = t - __builtin_ia32_cvtdq2pd256(k);
    const VI k6 =
        (VI)__builtin_ia32_pmuldq256((Ints8)__builtin_ia32_pmovsxdq256(k), (Ints8)(VI{6, 6, 6, 6}));
    const VI guess_offset = kShared ? k6 : offset + k6;
    V c[6];
    ISOWRENCH_CURVE_UNROLL
    for (int i = 0; i < 6; ++i) LaneGather(s0.guess.data() + i, guess_offset, c[i]);
    const V u = ((((c[5] * r + c[4]) * r + c[3]) * r + c[2]) * r + c[1]) * r + c[0];
    V cx[6];
    ISOWRENCH_CURVE_UNROLL
    for (int i = 0; i < 6; ++i) coefficient(kLaneX + i, cx[i]);
    // dx/du's coefficients (k + 1) x_(k+1), the table's products.
    V dx[5];
    if constexpr (kShared) {  // (the table's dx/du coefficients, splatted: memory operands)
      for (int i = 0; i < 5; ++i) dx[i] = s0.splat[static_cast<std::size_t>(kLaneDx + i)];
    } else {
      Multiples(cx, dx);
    }
    const V d = (((dx[4] * u + dx[3]) * u + dx[2]) * u + dx[1]) * u + dx[0];
    du = (((((cx[5] * u + cx[4]) * u + cx[3]) * u + cx[2]) * u + cx[1]) * u + cx[0] - xq) / d;
    const V v = u - du;
    const V one = lane_.one;
    const V un = (one < v) ? one : v;  // std::min(u - du, 1.0)
    V cy[6];
    ISOWRENCH_CURVE_UNROLL
    for (int i = 0; i < 6; ++i) coefficient(kLaneY + i, cy[i]);
    y = ((((cy[5] * un + cy[4]) * un + cy[3]) * un + cy[2]) * un + cy[1]) * un + cy[0];
    if constexpr (kSlope) {
      V b[5];
      if constexpr (kShared) {
        for (int i = 0; i < 5; ++i) b[i] = s0.splat[static_cast<std::size_t>(kLaneDy + i)];
      } else {
        Multiples(cy, b);
      }
      const V dy = (((b[4] * un + b[3]) * un + b[2]) * un + b[1]) * un + b[0];
      s = (d > ISOWRENCH_CURVE_SPLAT(0.0)) ? dy / d : ISOWRENCH_CURVE_SPLAT(0.0);
    }
  };
  // (the inside lanes in one segment: a two-segment curve's by its one end; a longer curve's by
  // comparing the first inside lane's, only for the equilibrium's samples (kSlope), whose lanes
  // the batch sorts by length: on the rigid tendon's unsorted lanes the test costs more than
  // it saves, 713.9 -> 716.8 instructions per evaluation)
  const unsigned inside_bits = ~outside_bits & 0xf;
  if (count_ <= 2 || !kSlope) {
    const unsigned segment_bits = count_ > 2 ? 1 : LaneBits<true>(minus_segment) & inside_bits;
    if (segment_bits == 0) {
      evaluate(std::true_type{}, 0);
    } else if (count_ <= 2 && segment_bits == inside_bits) {
      evaluate(std::true_type{}, 1);
    } else {
      evaluate(std::false_type{}, 0);
    }
  } else {
    const long long lead = minus_segment[__builtin_ctz(inside_bits)];  // (inside_bits != 0)
    const VI lead_lanes = VI{lead, lead, lead, lead};
    if ((LaneBits<true>((VI)(minus_segment == lead_lanes)) & inside_bits) == inside_bits) {
      evaluate(std::true_type{}, static_cast<int>(-lead));
    } else {
      evaluate(std::false_type{}, 0);
    }
  }
  if (outside_bits != 0) {
    if (below_bits != 0) {
      y = __builtin_ia32_blendvpd256(y, lane_.y0 + lane_.slope0 * (x - x0), (V)below);
      if constexpr (kSlope) s = __builtin_ia32_blendvpd256(s, lane_.slope0, (V)below);
    }
    if (above_bits != 0) {
      y = __builtin_ia32_blendvpd256(y, lane_.y1 + lane_.slope1 * (x - x1), (V)above);
      if constexpr (kSlope) s = __builtin_ia32_blendvpd256(s, lane_.slope1, (V)above);
    }
  }
  // Lanes inside whose Newton step exceeds 1e-8 (or is not a number): the scalar evaluation.
  // (vcmpnlepd: !(|du| <= 1e-8) in one compare)
  const unsigned far_bits =
      ~outside_bits & LaneBits<true>((VI)__builtin_ia32_cmppd256((V)((VI)du & lane_.magnitude),
                                                                 lane_.step_limit, 0x16));
  if (far_bits != 0) ScalarLanes<kSlope>(x, far_bits, y, s);
  value = y;
  if constexpr (kSlope) slope = s;
#undef ISOWRENCH_CURVE_SPLAT
}
#endif

// Factories (SmoothSegmentedFunctionFactory). Each checks OpenSim's conditions and throws
// isowrench::Error "muscle 'NAME': <what> ..." naming the property and value.

/// createFiberActiveForceLengthCurve(x0, x1, 1, x3, ylow = minimum_value, dydx, curviness 1).
SmoothCurve ActiveForceLengthCurve(const ActiveForceLengthCurveSpec& spec, double minimum_value,
                                   const std::string& muscle);
/// createFiberForceLengthCurve(e0, e1, kLow, kIso, curviness) with OpenSim's defaults for the
/// optional properties.
SmoothCurve FiberForceLengthCurve(const FiberForceLengthCurveSpec& spec, const std::string& muscle);
/// createTendonForceLengthCurve(eIso, kIso, fToe, curviness) with OpenSim's defaults for the
/// optional properties.
SmoothCurve TendonForceLengthCurve(const TendonForceLengthCurveSpec& spec,
                                   const std::string& muscle);

}  // namespace isowrench::muscle

#if defined(ISOWRENCH_CURVE_AVX2)
#pragma GCC diagnostic pop
#endif
