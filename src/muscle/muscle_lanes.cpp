// MuscleForceModel::Tension4: the batch force stage on four lanes (4-double vectors), the same
// operations in the same order as the scalar Tension (muscle_force.cpp), so the same bits per
// lane. Its own translation unit: the scalar force model's inlining (the one-posture path's
// speed) does not change with it.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "muscle/force_model_impl.hpp"

namespace isowrench {
namespace {

// The batch force stage's lanes (MuscleForceModel::Tension4). Tension4 is compiled for AVX2 (4
// doubles per instruction, the curves' coefficients by gathers) and for the baseline (GCC
// function versions: target("avx2") / target("default"), picked at load time), and never with FMA:
// the lanes must round every product and sum as the scalar code (compiled for the baseline) does,
// and with FMA available GCC would contract a * b + c into one fused, differently rounded,
// operation (C++ allows it by default, -ffp-contract=fast). Other compilers/targets: baseline.
#if defined(ISOWRENCH_CURVE_AVX2) && defined(__linux__) && !defined(ISOWRENCH_NO_CLONES)
#define ISOWRENCH_MUSCLE_AVX2 1
#endif
using LaneV = muscle::LaneDoubles;
using LaneI = muscle::LaneMasks;
#define ISOWRENCH_MUSCLE_SPLAT(x) (LaneV{(x), (x), (x), (x)})

// Per-lane square roots (std::sqrt's correctly rounded result, without its errno branch).
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE void LaneSqrt(const LaneV& x, LaneV& out) {
#if defined(ISOWRENCH_MUSCLE_AVX2)
  if constexpr (kAvx2) {
    out = __builtin_ia32_sqrtpd256(x);
    return;
  }
#endif
#if defined(__SSE2__)
  typedef double Half __attribute__((vector_size(16)));
  const Half lo = (Half)_mm_sqrt_pd((__m128d)__builtin_shufflevector(x, x, 0, 1));
  const Half hi = (Half)_mm_sqrt_pd((__m128d)__builtin_shufflevector(x, x, 2, 3));
  out = __builtin_shufflevector(lo, hi, 0, 1, 2, 3);
#else
  for (int l = 0; l < 4; ++l) out[l] = std::sqrt(x[l]);
#endif
}

// mask ? a : b per lane, for a mask whose lanes are all ones or zero (kAvx2: one vblendvpd on
// its sign bits; GCC's vector select first tests mask != 0 when it cannot tell).
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE LaneV Pick(const LaneI& mask, const LaneV& a, const LaneV& b) {
#if defined(ISOWRENCH_MUSCLE_AVX2)
  if constexpr (kAvx2) return __builtin_ia32_blendvpd256(b, a, (LaneV)mask);
#endif
  return mask ? a : b;
}

using muscle::LaneBits;

}  // namespace

// The normalized curves' values (and, kSlope, the iteration slopes of At) on four lanes, the
// same bits as ActiveValue / PassiveValue (SolveEvaluate for a Millard2012 curve, Active /
// Passive / Tendon for Thelen2003, lane by lane: its exponentials are scalar).
template <bool kSlope, int kCurve, bool kAvx2>
ISOWRENCH_MUSCLE_INLINE void MuscleForceModel::Impl::CurveLanes(const LaneV& x, LaneV& value,
                                                                LaneV& slope) const {
  if (type == ForceModelType::kMillard2012) {
    const muscle::SmoothCurve& c = kCurve == 0 ? active : kCurve == 1 ? passive : tendon;
    c.Lanes<kSlope, kAvx2>(x, value, slope);
    return;
  }
  for (int l = 0; l < 4; ++l) {
    const CurvePoint p = kCurve == 0 ? Active(x[l]) : kCurve == 1 ? Passive(x[l]) : Tendon(x[l]);
    value[l] = p.value;
    if (kSlope) slope[l] = p.slope;
  }
}

// Tension (rigid tendon) of four lengths, each > 0: RigidForce's operations on the lanes. Returns
// the lanes Tension must decide (a force beyond 1e150 N, or not a number).
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE unsigned MuscleForceModel::Impl::RigidLanes(const LaneV& length, double a,
                                                                    LaneV& force,
                                                                    unsigned& slack_bits) const {
  const LaneV along = length - ISOWRENCH_MUSCLE_SPLAT(tendon_slack_length);
  LaneI slack, short_fiber;
  muscle::LaneNotGreaterEqual<kAvx2>(
      along, ISOWRENCH_MUSCLE_SPLAT(pennation_min_fiber_along_tendon), slack);
  LaneV l;
  LaneSqrt<kAvx2>(ISOWRENCH_MUSCLE_SPLAT(height_squared) + along * along, l);
  muscle::LaneNotGreater<kAvx2>(l, ISOWRENCH_MUSCLE_SPLAT(min_fiber), short_fiber);
  slack |= short_fiber;
  LaneV cos_phi = ISOWRENCH_MUSCLE_SPLAT(1.0);
  if (pennated) {
    const LaneI within = (ISOWRENCH_MUSCLE_SPLAT(height) / l) < ISOWRENCH_MUSCLE_SPLAT(max_sin);
    cos_phi = within ? along / l : ISOWRENCH_MUSCLE_SPLAT(max_cos);
  }
  // (slack lanes: any length inside the curves' range, not evaluated)
  const LaneV norm =
      slack ? ISOWRENCH_MUSCLE_SPLAT(1.0) : l * ISOWRENCH_MUSCLE_SPLAT(inv_optimal_fiber_length);
  LaneV fal, fpe, unused;
  CurveLanes<false, 0, kAvx2>(norm, fal, unused);
  CurveLanes<false, 1, kAvx2>(norm, fpe, unused);
  const LaneV f = ISOWRENCH_MUSCLE_SPLAT(max_force * a) * fal * cos_phi +
                  ISOWRENCH_MUSCLE_SPLAT(max_force) * fpe * cos_phi;
  force = slack ? ISOWRENCH_MUSCLE_SPLAT(0.0) : f;
  slack_bits = LaneBits<kAvx2>(slack);
  LaneI large;
  muscle::LaneNotLessEqual<kAvx2>(f, ISOWRENCH_MUSCLE_SPLAT(1e150), large);
  return LaneBits<kAvx2>(large) & ~slack_bits;
}

// At<false>(l, length, a)'s residual, slope, tendon force and fiber force along the tendon
// (Iterate) on four lanes, the same operations in the same order (a and max_force * a
// splatted by the caller).
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE void MuscleForceModel::Impl::IterateLanes(
    const LaneV& l, const LaneV& length, const LaneV& a, const LaneV& max_force_a, LaneV& residual,
    LaneV& slope, LaneV& tendon_force, LaneV& fiber_along) const {
#define S ISOWRENCH_MUSCLE_SPLAT
  LaneV sin_phi = S(0.0), cos_phi = lane.one;
  if (pennated) {  // Pennation
    const LaneV s = (LaneI)(l > lane.pennation_min_fiber) ? lane.height / l : lane.max_sin;
    const LaneI within = s < lane.max_sin;
    LaneV root;
    LaneSqrt<kAvx2>((LaneV)((LaneI)(lane.one - s * s) & lane.magnitude), root);
    sin_phi = within ? s : lane.max_sin;
    cos_phi = within ? root : lane.max_cos;
  }
  const LaneV norm = l * lane.inv_optimal_fiber_length;
  const LaneV tendon_length = length - l * cos_phi;
  const LaneV norm_tendon = tendon_length * lane.inv_tendon_slack_length;
  LaneV fal, dfal, fpe, dfpe, fse, dfse;
  CurveLanes<true, 0, kAvx2>(norm, fal, dfal);
  CurveLanes<true, 1, kAvx2>(norm, fpe, dfpe);
  CurveLanes<true, 2, kAvx2>(norm_tendon, fse, dfse);
  const LaneV active_force = max_force_a * fal;
  const LaneV passive_force = lane.max_force * fpe;
  const LaneV fiber = active_force + passive_force;
  const LaneV dfiber = (a * dfal + dfpe) * lane.force_per_optimal_length;
  const LaneV dcos = sin_phi * sin_phi / (l * cos_phi);
  fiber_along = fiber * cos_phi;
  const LaneV dfiber_along = dfiber * cos_phi + fiber * dcos;
  tendon_force = lane.max_force * fse;
  const LaneV tendon_stiffness = dfse * lane.force_per_tendon_slack_length;
  const LaneV r = fiber_along - tendon_force;
  residual = (LaneI)((l - l) == S(0.0)) ? r : lane.nan;
  slope = dfiber_along + tendon_stiffness / cos_phi;
#undef S
}

// Tension (compliant tendon) of four lengths, each > 0 and finite: Solve's common path on the
// lanes, each lane taking OpenSim's iteration's steps (masked until every lane has finished)
// and then the polish's Newton steps. Returns the lanes Tension must decide: OpenSim's
// iteration not converging, its result outside the bracket, a bisection or minimum-length
// step of the polish, a fiber at its minimum length, a number beyond 1e150, not a number.
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE unsigned MuscleForceModel::Impl::CompliantLanes(
    const LaneV& length, double a, LaneV& force, unsigned& slack_bits) const {
#define S ISOWRENCH_MUSCLE_SPLAT
  const LaneV slack_along = length - S(tendon_slack_length);
  const LaneI slack = (LaneI)(slack_along <= S(min_fiber_along_tendon));
  slack_bits = LaneBits<kAvx2>(slack);
  LaneV hi;
  LaneSqrt<kAvx2>(S(height_squared) + slack_along * slack_along, hi);
  // OpenSimIteration's start.
  const LaneV along = length - S(1.01 * tendon_slack_length);
  LaneV root;
  LaneSqrt<kAvx2>(S(height_squared) + along * along, root);
  LaneV lce =
      (LaneI)(along >= S(pennation_min_fiber_along_tendon)) ? root : lane.pennation_min_fiber;
  if (clamp_initial_guess) lce = (LaneI)(lce < lane.min_fiber) ? lane.min_fiber : lce;
  lce = slack ? lane.min_fiber : lce;  // (slack lanes: a harmless fiber, not used)
  const auto magnitude = [this](const LaneV& v) ISOWRENCH_MUSCLE_LAMBDA_INLINE {
    return (LaneV)((LaneI)v & lane.magnitude);
  };
  const LaneV opensim_tolerance_v = S(opensim_tolerance);
  const LaneV a_lanes = S(a), max_force_a = S(max_force * a);
  const LaneV max_iterations = S(static_cast<double>(opensim_max_iterations));
  const LaneI none = LaneI{0, 0, 0, 0};
  // The lanes' state: OpenSim's iteration (lce, lce_prev, ferr, ferr_prev, slope, h, iter),
  // the last sample (ferr, last_slope, tendon_force, fiber_along), the polish (x, lo, hi,
  // lo_negative, step_before, step). Masks: `first` (OpenSim's first sample pending),
  // `opensim` (a sample at lce pending), `entering` (OpenSim's iteration just ended),
  // `polish` (a sample at x pending, then the polish's loop head), `done`, `scalar`.
  LaneV ferr = S(0.0), slope = ferr, tendon_force = ferr, fiber_along = ferr, last_slope = ferr;
  LaneV ferr_prev = ferr, lce_prev = lce, h = lane.one, iter = S(0.0);
  LaneV x = lce, lo = lane.min_fiber, step_before = hi - lo, step = step_before;
  LaneI first = ~slack, opensim = none, entering = none, polish = none, lo_negative = none;
  LaneI scalar = none, done = slack;
  for (int round = 0; round < 64; ++round) {
    // Lanes leaving OpenSim's iteration: converged and inside the bracket, or the scalar path.
    if (LaneBits<kAvx2>(entering) != 0) {
      const LaneI converged = (LaneI)(magnitude(ferr) < opensim_tolerance_v);
      const LaneV clamped = (LaneI)(lce < lo) ? lo : (LaneI)(hi < lce) ? hi : lce;
      const LaneI inside = converged & (LaneI)(clamped == lce);
      scalar |= entering & ~inside;
      x = Pick<kAvx2>(entering, lce, x);
      // (the polish's checks below run on OpenSim's last sample)
      polish |= entering & inside;
    }
    // The polish's loop head on the lanes with a new sample (entering or sampled).
    LaneI check = (entering & polish) | (polish & ~entering & ~done & ~scalar);
    entering = LaneI{0, 0, 0, 0};
    if (LaneBits<kAvx2>(check) != 0) {
      const LaneI within = (LaneI)(magnitude(ferr) <= lane.tolerance);
      done |= check & within;
      LaneI go = check & ~within;
      const LaneI negative = (LaneI)(ferr < S(0.0));
      lo = Pick<kAvx2>(go & negative, x, lo);
      lo_negative |= go & negative;
      hi = Pick<kAvx2>(go & ~negative, x, hi);
      const LaneI rounding = (LaneI)(hi - lo <= lane.rounding * hi);
      done |= go & rounding;
      go &= ~rounding;
      const LaneV next = x - ferr / last_slope;
      const LaneI slow = (LaneI)(magnitude(next - x) > lane.half * magnitude(step_before));
      step_before = Pick<kAvx2>(go, step, step_before);
      const LaneI newton = (LaneI)(next > lo) & (LaneI)(next < hi) & ~slow;
      scalar |= go & ~newton;  // bisection or the minimum-length check
      go &= newton;
      step = Pick<kAvx2>(go, next - x, step);
      x = Pick<kAvx2>(go, next, x);
      polish = (polish & ~check) | go;  // (the lanes that need a sample at x)
    }
    if (LaneBits<kAvx2>(first | opensim | polish) == 0) break;
    // One sample per lane that needs one: OpenSim's at lce (its inner loop's step from
    // lce_prev), the polish's at x.
    if (LaneBits<kAvx2>(opensim) != 0) {
      const LaneV delta = -h * ferr_prev / slope;
      const LaneI big = (LaneI)(magnitude(delta) > lane.significant_real);
      const LaneV sign = (LaneV)((LaneI)(delta > S(0.0)) & (LaneI)lane.one) -
                         (LaneV)((LaneI)(delta < S(0.0)) & (LaneI)lane.one);
      LaneV next = big ? lce_prev + delta : lce_prev - sign * lane.sqrt_eps;
      next = (LaneI)(next < lane.min_fiber) ? lane.min_fiber : next;
      lce = Pick<kAvx2>(opensim, next, lce);
      h = Pick<kAvx2>(opensim & ~big, S(0.0), h);
    }
    const LaneV point = Pick<kAvx2>(first | opensim, lce, x);
    LaneV r, sl, tf, fa;
    IterateLanes<kAvx2>(point, length, a_lanes, max_force_a, r, sl, tf, fa);
    const LaneI sampled = first | opensim | polish;
    ferr = Pick<kAvx2>(sampled, r, ferr);
    last_slope = Pick<kAvx2>(sampled, sl, last_slope);
    tendon_force = Pick<kAvx2>(sampled, tf, tendon_force);
    fiber_along = Pick<kAvx2>(sampled, fa, fiber_along);
    // OpenSim's inner loop after its sample: break when h <= sqrt(eps), else halve h and
    // repeat while |ferr| >= |ferr_prev|; then its outer loop's tail and head.
    if (LaneBits<kAvx2>(opensim) != 0) {
      const LaneI brk = (LaneI)(h <= lane.sqrt_eps);
      h = Pick<kAvx2>(opensim & ~brk, lane.half * h, h);
      const LaneI inner = opensim & ~brk & (LaneI)(magnitude(ferr) >= magnitude(ferr_prev));
      LaneI tail = opensim & ~inner;
      const LaneI same = (LaneI)(lce == lce_prev) & (LaneI)(ferr == ferr_prev);
      LaneI leave = tail & same;
      tail &= ~same;
      ferr_prev = Pick<kAvx2>(tail, ferr, ferr_prev);
      lce_prev = Pick<kAvx2>(tail, lce, lce_prev);
      slope = Pick<kAvx2>(tail, last_slope, slope);
      iter = Pick<kAvx2>(tail, iter + lane.one, iter);
      const LaneI again = tail & (LaneI)(magnitude(ferr) > opensim_tolerance_v) &
                          (LaneI)(iter < max_iterations) &
                          (LaneI)(magnitude(ferr) >= magnitude(ferr_prev));
      h = Pick<kAvx2>(again, lane.one, h);
      leave |= tail & ~again;
      opensim = inner | again;
      entering = leave;
    }
    // OpenSim's first sample: its while conditions (|ferr| >= |ferr_prev|: not a number).
    if (LaneBits<kAvx2>(first) != 0) {
      ferr_prev = Pick<kAvx2>(first, ferr, ferr_prev);
      slope = Pick<kAvx2>(first, last_slope, slope);
      const LaneI start = first & (LaneI)(magnitude(ferr) > opensim_tolerance_v) &
                          (LaneI)(iter < max_iterations) &
                          (LaneI)(magnitude(ferr) >= magnitude(ferr_prev));
      opensim |= start;
      entering |= first & ~start;
      first = none;
    }
  }
  scalar |= ~done & ~scalar;  // (still iterating after 64 samples)
  const LaneI valid = (LaneI)(magnitude(tendon_force) <= S(1e150)) &
                      (LaneI)(magnitude(fiber_along) <= S(1e150)) & (LaneI)(x <= S(1e150));
  const LaneI minimum =
      ~lo_negative & (LaneI)(x <= lane.min_fiber) & (LaneI)(ferr > lane.tolerance);
  scalar |= ~slack & (~valid | minimum);
  force = slack ? S(0.0) : tendon_force;
  return LaneBits<kAvx2>(scalar & ~slack);
#undef S
}

namespace {

// The four lanes' statuses for each set of slack lanes (bit l: lane l kSlack, else
// kEquilibrium): one copy instead of four selects.
struct SlackStatuses {
  MuscleForceStatus status[16][4];
};
constexpr SlackStatuses MakeSlackStatuses() {
  SlackStatuses s{};
  for (unsigned bits = 0; bits < 16; ++bits) {
    for (unsigned l = 0; l < 4; ++l) {
      s.status[bits][l] =
          (bits >> l) & 1 ? MuscleForceStatus::kSlack : MuscleForceStatus::kEquilibrium;
    }
  }
  return s;
}
constexpr SlackStatuses kSlackStatuses = MakeSlackStatuses();

// MuscleForceModel::Tension4 (the versions below: a free function; its arguments in
// Tension4's order, the model's Impl last).
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE void TensionLanesOf(const MuscleForceModel& model, const double* length,
                                            double activation, double* force,
                                            MuscleForceStatus* status,
                                            const MuscleForceModel::Impl& m) {
  unsigned scalar = 0xf;
  if (m.fast_tension && m.type != ForceModelType::kConstant && activation >= 0.0 &&
      activation <= 1.0) {
    const double a = std::max(activation, m.min_activation);
    LaneV L;
    std::memcpy(&L, length, sizeof L);
    // (lengths not > 0, and for a compliant tendon not finite, go to Tension)
    const LaneI usable =
        m.rigid ? (LaneI)(L > ISOWRENCH_MUSCLE_SPLAT(0.0))
                : (LaneI)(L > ISOWRENCH_MUSCLE_SPLAT(0.0)) &
                      (LaneI)(L <= ISOWRENCH_MUSCLE_SPLAT(std::numeric_limits<double>::max()));
    const LaneV safe = usable ? L : ISOWRENCH_MUSCLE_SPLAT(m.tendon_slack_length);
    LaneV f;
    unsigned slack = 0;
    scalar = (m.rigid ? m.RigidLanes<kAvx2>(safe, a, f, slack)
                      : m.CompliantLanes<kAvx2>(safe, a, f, slack)) |
             (LaneBits<kAvx2>(usable) ^ 0xf);
    std::memcpy(force, &f, sizeof f);
    std::memcpy(status, kSlackStatuses.status[slack & 0xf], sizeof kSlackStatuses.status[0]);
  }
  for (int l = 0; scalar != 0 && l < 4; ++l) {
    if (scalar & (1u << l)) force[l] = model.Tension(length[l], activation, &status[l]);
  }
}

// MuscleForceModel::TensionBlock: a compliant tendon's taut lengths sorted and handed to the
// lanes four neighbours at a time (those Tension decides, and slack ones, sorted out first),
// other models four at a time in the given order. Which lengths share a lane group changes no
// bit: each lane's operations never depend on another lane's.
template <bool kAvx2>
ISOWRENCH_MUSCLE_INLINE void TensionBlockOf(const MuscleForceModel& model, const double* length,
                                            long n, double activation, double* force,
                                            MuscleForceStatus* status,
                                            const MuscleForceModel::Impl& m) {
  if (!m.fast_tension || m.type == ForceModelType::kConstant || m.rigid || !(activation >= 0.0) ||
      !(activation <= 1.0)) {
    long i = 0;
    for (; i + 4 <= n; i += 4)
      TensionLanesOf<kAvx2>(model, length + i, activation, force + i, status + i, m);
    for (; i < n; ++i) force[i] = model.Tension(length[i], activation, &status[i]);
    return;
  }
  const double a = std::max(activation, m.min_activation);
  constexpr int kChunk = 512;
  int queue[kChunk], redo[kChunk];
  for (long c = 0; c < n; c += kChunk) {
    const int size = static_cast<int>(std::min<long>(kChunk, n - c));
    const double* L = length + c;
    double* F = force + c;
    MuscleForceStatus* St = status + c;
    int count = 0, redo_count = 0;
    for (int i = 0; i < size; ++i) {
      // (as TensionLanesOf and CompliantLanes: not > 0 or not finite to Tension; slack. NaN
      // must not reach the sort)
      if (!(L[i] > 0.0) || !(L[i] <= std::numeric_limits<double>::max())) {
        redo[redo_count++] = i;
      } else if (L[i] - m.tendon_slack_length <= m.min_fiber_along_tendon) {
        F[i] = 0.0;
        St[i] = MuscleForceStatus::kSlack;
      } else {
        queue[count++] = i;
      }
    }
    // The taut lengths sorted (into kBuckets equal bins between the shortest and the longest,
    // a counting sort), four neighbours per lane group: their fibers fall in the same curve
    // segments more often, and the group's equilibrium waits less for its slowest lane.
    // (bins per 256 lengths, batch-compliant instructions per evaluation: 64 1,227.7, 128
    // 1,225.3, 250 1,226.4; 512 lengths in 256 bins: 1,198.2)
    constexpr int kBuckets = 256;
    static_assert(kBuckets <= 256, "bins numbered by an unsigned char");
    double shortest = std::numeric_limits<double>::max(), longest = 0.0;
    for (int k = 0; k < count; ++k) {
      shortest = std::min(shortest, L[queue[k]]);
      longest = std::max(longest, L[queue[k]]);
    }
    const double span = longest - shortest;  // (finite: the lengths are finite and > 0)
    const double scale = span > 1e-300 ? (kBuckets - 0.5) / span : 0.0;
    int start[kBuckets + 1] = {};
    unsigned char bucket[kChunk];
    for (int k = 0; k < count; ++k) {
      bucket[k] = static_cast<unsigned char>((L[queue[k]] - shortest) * scale);  // < kBuckets
      ++start[bucket[k] + 1];
    }
    for (int b = 0; b < kBuckets; ++b) start[b + 1] += start[b];
    int sorted[kChunk];
    for (int k = 0; k < count; ++k) sorted[start[bucket[k]]++] = queue[k];
    std::memcpy(queue, sorted, sizeof(int) * static_cast<std::size_t>(count));
    for (int k = 0; k < count; k += 4) {
      // (a last group of fewer than four repeats its last length)
      const int used = std::min(4, count - k);
      const int last = queue[k + used - 1];
      int at[4];
      for (int l = 0; l < 4; ++l) at[l] = l < used ? queue[k + l] : last;
      // (TensionLanesOf's compliant path: every length here is usable and taut)
      const LaneV quad = {L[at[0]], L[at[1]], L[at[2]], L[at[3]]};
      LaneV f;
      unsigned slack = 0;
      const unsigned scalar = m.CompliantLanes<kAvx2>(quad, a, f, slack);
      for (int l = 0; l < used; ++l) {
        if (scalar & (1u << l)) {
          F[at[l]] = model.Tension(L[at[l]], activation, &St[at[l]]);
        } else {
          F[at[l]] = f[l];
          St[at[l]] = MuscleForceStatus::kEquilibrium;
        }
      }
    }
    for (int k = 0; k < redo_count; ++k) {
      const int i = redo[k];
      F[i] = model.Tension(L[i], activation, &St[i]);
    }
  }
}

#if defined(ISOWRENCH_MUSCLE_AVX2)
__attribute__((target("avx2"))) void TensionBlockLanes(const MuscleForceModel& model,
                                                       const double* length, long n,
                                                       double activation, double* force,
                                                       MuscleForceStatus* status,
                                                       const MuscleForceModel::Impl& m) {
  TensionBlockOf<true>(model, length, n, activation, force, status, m);
}
__attribute__((target("default")))
#endif
void TensionBlockLanes(const MuscleForceModel& model, const double* length, long n,
                        double activation, double* force, MuscleForceStatus* status,
                        const MuscleForceModel::Impl& m) {
  TensionBlockOf<false>(model, length, n, activation, force, status, m);
}

#if defined(ISOWRENCH_MUSCLE_AVX2)
__attribute__((target("avx2"))) void TensionLanes(const MuscleForceModel& model,
                                                  const double* length, double activation,
                                                  double* force, MuscleForceStatus* status,
                                                  const MuscleForceModel::Impl& m) {
  TensionLanesOf<true>(model, length, activation, force, status, m);
}
__attribute__((target("default")))
#endif
void TensionLanes(const MuscleForceModel& model, const double* length, double activation,
                  double* force, MuscleForceStatus* status, const MuscleForceModel::Impl& m) {
  TensionLanesOf<false>(model, length, activation, force, status, m);
}

}  // namespace

void MuscleForceModel::Tension4(const double length[4], double activation, double force[4],
                                MuscleForceStatus status[4]) const {
  // (Tension4's arguments in place: the call is a jump)
  TensionLanes(*this, length, activation, force, status, *impl_);
}

void MuscleForceModel::TensionBlock(const double* length, long n, double activation, double* force,
                                    MuscleForceStatus* status) const {
  TensionBlockLanes(*this, length, n, activation, force, status, *impl_);
}

}  // namespace isowrench
