// Isometric muscle force: OpenSim's Thelen2003Muscle and Millard2012EquilibriumMuscle at zero
// velocity (docs/muscle.md gives every formula and its source). Ported from opensim-core
// (Apache-2.0, commit 0435b081d):
//   MuscleFixedWidthPennationModel.cpp  extendFinalizeFromProperties, calcPennationAngle,
//                                       calcFiberLength, calcTendonLength, the partials
//   Millard2012EquilibriumMuscle.cpp    extendFinalizeFromProperties (curve floors, minimum
//                                       fiber length), calcMuscleLengthInfo (rigid tendon),
//                                       estimateMuscleFiberState (the Newton iteration),
//                                       computeFiberEquilibrium (tolerance, 200 iterations)
//   Thelen2003Muscle.cpp                extendFinalizeFromProperties, calcfal, calcfpe, calcfse
//                                       and their derivatives, initMuscleState,
//                                       computeInitialFiberEquilibrium (tolerance, 20 iterations)
//   MuscleFirstOrderActivationDynamicModel.cpp  clampActivation, the minimum_activation range

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "isowrench/error.hpp"
#include "isowrench/muscle.hpp"
#include "muscle/smooth_curve.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

#if defined(__GNUC__)
#define ISOWRENCH_MUSCLE_INLINE inline __attribute__((always_inline))
#else
#define ISOWRENCH_MUSCLE_INLINE inline
#endif

// SimTK constants (SimTKcommon/Scalar.h): Eps, SignificantReal = Eps^(7/8), SqrtEps.
constexpr double kSimTKEps = std::numeric_limits<double>::epsilon();
const double kSignificantReal = std::pow(kSimTKEps, 0.875);
const double kSqrtEps = std::sqrt(kSimTKEps);
// The equilibrium tolerance of isowrench's solve, relative to max_force (OpenSim stops at
// 1e-8 * max_force; the bracketed Newton polish continues to this).
constexpr double kEquilibriumRelativeTolerance = 1e-13;
// Millard2012EquilibriumMuscle.cpp MIN_NONZERO_DAMPING_COEFFICIENT.
constexpr double kMinNonzeroDamping = 0.001;

std::string MuscleNumber(double v) { return util::FormatNumber(v, 6); }

// The batch force stage's lanes (MuscleForceModel::Tension4). Tension4 is compiled for AVX2 (4
// doubles per instruction) and for the baseline, picked at load time, and never with FMA: the
// lanes must round every product and sum as the scalar code (compiled for the baseline) does,
// and with FMA available GCC would contract a * b + c into one fused, differently rounded,
// operation (C++ allows it by default, -ffp-contract=fast). Other compilers/targets: baseline.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ISOWRENCH_NO_CLONES)
#define ISOWRENCH_MUSCLE_LANES __attribute__((target_clones("avx2", "default")))
#else
#define ISOWRENCH_MUSCLE_LANES
#endif
using LaneV = muscle::LaneDoubles;
using LaneI = muscle::LaneMasks;
#define ISOWRENCH_MUSCLE_SPLAT(x) (LaneV{(x), (x), (x), (x)})

// Per-lane square roots (std::sqrt's correctly rounded result, without its errno branch).
ISOWRENCH_MUSCLE_INLINE void LaneSqrt(const LaneV& x, LaneV& out) {
#if defined(__SSE2__)
  typedef double Half __attribute__((vector_size(16)));
  const Half lo = (Half)_mm_sqrt_pd((__m128d)__builtin_shufflevector(x, x, 0, 1));
  const Half hi = (Half)_mm_sqrt_pd((__m128d)__builtin_shufflevector(x, x, 2, 3));
  out = __builtin_shufflevector(lo, hi, 0, 1, 2, 3);
#else
  for (int l = 0; l < 4; ++l) out[l] = std::sqrt(x[l]);
#endif
}

using muscle::LaneBits;

}  // namespace

struct MuscleForceModel::Impl {
  std::string muscle;
  std::string limitation;
  ForceModelType type = ForceModelType::kConstant;
  bool rigid = false;
  double max_force = 1.0;
  double optimal_fiber_length = 0.0, inv_optimal_fiber_length = 0.0;
  double tendon_slack_length = 0.0, inv_tendon_slack_length = 0.0;
  double force_per_optimal_length = 0.0;       // N/m, max_force / l_o
  double force_per_tendon_slack_length = 0.0;  // N/m, max_force / l_Ts (0 if l_Ts is 0)
  // MuscleFixedWidthPennationModel
  bool pennated = false;  // pennation_angle_at_optimal > Eps
  double height = 0.0;    // parallelogram height l_o sin(phi_o)
  double max_pennation = 0.0, max_sin = 0.0, max_cos = 1.0;
  double pennation_min_fiber = 0.0, pennation_min_fiber_along_tendon = 0.0;
  // The muscle's clamp
  double min_fiber = 0.0, min_fiber_along_tendon = 0.0;
  double min_activation = 0.0;
  // Solver settings
  double tolerance = 0.0;
  double opensim_tolerance = 0.0;
  int opensim_max_iterations = 0;
  bool clamp_initial_guess = false;
  // Tension() may run the force-only computation: a force model whose curve slopes, max_force,
  // 1 / l_o and 1 / l_Ts are small enough that no field Evaluate checks can overflow while the
  // force and the fiber force stay below 1e150 N.
  bool fast_tension = false;
  // Millard2012 curves
  muscle::SmoothCurve active, passive, tendon;
  // Thelen2003 constants
  double kshape_active = 1.0;
  double passive_rate = 0.0, passive_scale = 0.0;
  double toe_strain = 0.0, linear_slope = 0.0, toe_scale = 0.0, toe_rate = 0.0;

  CurvePoint Active(double x) const {
    if (type == ForceModelType::kMillard2012) return active.Evaluate(x);
    if (type == ForceModelType::kConstant) return {1.0, 0.0};
    // Thelen2003Muscle::calcfal, calcDfalDlceN.
    const double d = x - 1.0;
    const double f = std::exp(-d * d / kshape_active);
    return {f, -2.0 * d / kshape_active * f};
  }
  CurvePoint Passive(double x) const {
    if (type == ForceModelType::kMillard2012) return passive.Evaluate(x);
    if (type == ForceModelType::kConstant || !(x > 1.0)) return {0.0, 0.0};
    // Thelen2003Muscle::calcfpe, calcDfpeDlceN.
    const double e = std::exp(passive_rate * (x - 1.0));
    return {(e - 1.0) * passive_scale, passive_rate * e * passive_scale};
  }
  CurvePoint Tendon(double x) const {
    if (type == ForceModelType::kMillard2012) return tendon.Evaluate(x);
    if (type == ForceModelType::kConstant) return {0.0, 0.0};
    // Thelen2003Muscle::calcfse, calcDfseDtlN (kToe 3, Ftoe 0.33).
    const double strain = x - 1.0;
    if (strain > toe_strain) return {linear_slope * (strain - toe_strain) + 0.33, linear_slope};
    if (strain > 0.0) {
      const double e = std::exp(toe_rate * strain);
      return {toe_scale * (e - 1.0), toe_scale * toe_rate * e};
    }
    return {0.0, 0.0};
  }

  // The values alone (the same bits as Active(x).value, Passive(x).value).
  double ActiveValue(double x) const {
    return type == ForceModelType::kMillard2012 ? active.Value(x) : Active(x).value;
  }
  double PassiveValue(double x) const {
    return type == ForceModelType::kMillard2012 ? passive.Value(x) : Passive(x).value;
  }

  // MuscleFixedWidthPennationModel::calcFiberLength(muscleLength, tendonLength).
  double FiberLength(double length, double tendon_length) const {
    const double along = length - tendon_length;
    return along >= pennation_min_fiber_along_tendon ? std::sqrt(height * height + along * along)
                                                     : pennation_min_fiber;
  }

  // Pennation of a fiber of length l (calcPennationAngle without the asin).
  void Pennation(double l, double* sin_phi, double* cos_phi) const {
    if (!pennated) {
      *sin_phi = 0.0;
      *cos_phi = 1.0;
      return;
    }
    const double s = l > pennation_min_fiber ? height / l : max_sin;
    if (s < max_sin) {
      *sin_phi = s;
      *cos_phi = std::sqrt(std::abs(1.0 - s * s));  // (> 0; abs: no errno path)
    } else {
      *sin_phi = max_sin;
      *cos_phi = max_cos;
    }
  }

  double PennationAngle(double sin_phi) const {
    if (!pennated) return 0.0;
    return sin_phi < max_sin ? std::asin(sin_phi) : max_pennation;
  }

  // Everything the equilibrium needs at fiber length l (compliant tendon, zero velocity:
  // f_V = 1 and no damping force).
  struct Sample {
    double sin_phi = 0.0, cos_phi = 1.0;
    double active = 0.0, passive = 0.0;  // N along the fiber
    double tendon_force = 0.0;           // N
    double tendon_stiffness = 0.0;       // N/m, dF_T/dl_T
    double norm_tendon_length = 0.0;
    double fiber_along = 0.0;   // N, fiber force along the tendon
    double dfiber_along = 0.0;  // N/m, d(fiber force along tendon)/dl
    double residual = 0.0;      // N
    double slope = 0.0;         // N/m, d residual / dl
  };

  // kExact: the curves' exact slopes (the reported stiffness); false: a Millard2012 curve's
  // iteration slope (SmoothCurve::SolveEvaluate). The values are the same bits either way.
  template <bool kExact = false>
  ISOWRENCH_MUSCLE_INLINE Sample At(double l, double length, double a) const {
    Sample s;
    Pennation(l, &s.sin_phi, &s.cos_phi);
    const double norm = l * inv_optimal_fiber_length;
    const double tendon_length = length - l * s.cos_phi;  // calcTendonLength
    s.norm_tendon_length = tendon_length * inv_tendon_slack_length;
    CurvePoint fal, fpe, fse;
    if (!kExact && type == ForceModelType::kMillard2012) {
      fal = active.SolveEvaluate(norm);
      fpe = passive.SolveEvaluate(norm);
      fse = tendon.SolveEvaluate(s.norm_tendon_length);
    } else {
      fal = Active(norm);
      fpe = Passive(norm);
      fse = Tendon(s.norm_tendon_length);
    }
    s.active = max_force * a * fal.value;
    s.passive = max_force * fpe.value;
    const double fiber = s.active + s.passive;
    const double dfiber = (a * fal.slope + fpe.slope) * force_per_optimal_length;
    // d cos(phi) / dl = sin^2(phi) / (l cos(phi)) (Thelen2003Muscle::calcDFmATDlce;
    // Millard2012EquilibriumMuscle::calc_DFiberForceAT_DFiberLength).
    // (0 without pennation: l cos(phi) >= l >= min_fiber > 0)
    const double dcos = s.sin_phi * s.sin_phi / (l * s.cos_phi);
    s.fiber_along = fiber * s.cos_phi;
    s.dfiber_along = dfiber * s.cos_phi + fiber * dcos;
    s.tendon_force = max_force * fse.value;
    s.tendon_stiffness = fse.slope * force_per_tendon_slack_length;
    s.residual = s.fiber_along - s.tendon_force;
    // d l_T / dl = -1 / cos(phi) (calc_DTendonLength_DfiberLength).
    s.slope = s.dfiber_along + s.tendon_stiffness / s.cos_phi;
    if (!std::isfinite(l)) s.residual = std::numeric_limits<double>::quiet_NaN();
    return s;
  }

  // What the iterations read of a sample (At, inlined: the rest is not computed). The same
  // values as At<true>'s, bit for bit.
  struct Step {
    double residual = 0.0, slope = 0.0, tendon_force = 0.0, fiber_along = 0.0;
  };
  Step Iterate(double l, double length, double a) const {
    const Sample s = At(l, length, a);
    return {s.residual, s.slope, s.tendon_force, s.fiber_along};
  }

  // OpenSim's own equilibrium iteration, step for step: Millard2012EquilibriumMuscle::
  // estimateMuscleFiberState (static solution) and Thelen2003Muscle::initMuscleState with
  // zero path speed (f_V = 1): Newton's method on the fiber length with step halving while
  // |error| does not decrease, the fiber clamped at its minimum length. Returns whether it
  // converged to OpenSim's tolerance; *l is where it stopped.
  bool OpenSimIteration(double length, double a, double* l, Step* last, int* iterations) const {
    double lce = FiberLength(length, 1.01 * tendon_slack_length);
    if (clamp_initial_guess) lce = std::max(lce, min_fiber);
    Step s = Iterate(lce, length, a);
    double ferr = s.residual, ferr_prev = ferr, lce_prev = lce, slope = s.slope;
    int iter = 0;
    while (std::abs(ferr) > opensim_tolerance && iter < opensim_max_iterations) {
      double h = 1.0;
      while (std::abs(ferr) >= std::abs(ferr_prev)) {
        const double delta = -h * ferr_prev / slope;
        if (std::abs(delta) > kSignificantReal) {
          lce = lce_prev + delta;
        } else {
          // SimTK::sign: -1, 0 or 1.
          lce = lce_prev - static_cast<double>((delta > 0) - (delta < 0)) * kSqrtEps;
          h = 0;
        }
        if (lce < min_fiber) lce = min_fiber;
        s = Iterate(lce, length, a);
        ferr = s.residual;
        if (h <= kSqrtEps) break;
        h = 0.5 * h;
      }
      // Back where this iteration started (the fiber held at its minimum length): every
      // further iteration repeats this one exactly, so OpenSim ends in this state.
      if (lce == lce_prev && ferr == ferr_prev) break;
      ferr_prev = ferr;
      lce_prev = lce;
      slope = s.slope;
      ++iter;
    }
    *l = lce;
    *last = s;
    *iterations = iter;
    return std::abs(ferr) < opensim_tolerance;
  }

  MuscleForce Slack(double length, double a) const {
    MuscleForce f;
    f.status = MuscleForceStatus::kSlack;
    f.activation = a;
    f.fiber_length = min_fiber;
    double sin_phi = 0.0, cos_phi = 1.0;
    Pennation(min_fiber, &sin_phi, &cos_phi);
    f.pennation_angle = PennationAngle(sin_phi);
    if (tendon_slack_length > 0.0) {
      f.tendon_strain = (length - min_fiber_along_tendon) * inv_tendon_slack_length - 1.0;
    }
    return f;
  }

  // The rigid tendon's fiber and force (Millard2012EquilibriumMuscle::calcMuscleLengthInfo,
  // ignore_tendon_compliance): false when the fiber is at its minimum length, clamped with zero
  // velocity (isFiberStateClamped), producing no force (calcMuscleDynamicsInfo).
  struct RigidFiber {
    double l = 0.0, sin_phi = 0.0, cos_phi = 1.0, norm = 0.0;
    double active_force = 0.0, passive_force = 0.0;  // N along the tendon
  };
  ISOWRENCH_MUSCLE_INLINE bool RigidForce(double length, double a, RigidFiber* r) const {
    // FiberLength(length, tendon_slack_length) and Pennation(l): below the pennation model's
    // shortest fiber along the tendon the fiber is at pennation_min_fiber <= min_fiber, so
    // clamped; above it cos(phi) = (L - l_Ts) / l (the parallelogram).
    const double along = length - tendon_slack_length;
    if (!(along >= pennation_min_fiber_along_tendon)) return false;
    r->l = std::sqrt(height * height + along * along);
    if (!(r->l > min_fiber)) return false;
    if (!pennated) {
      r->sin_phi = 0.0;
      r->cos_phi = 1.0;
    } else if (height / r->l < max_sin) {
      r->sin_phi = height / r->l;
      r->cos_phi = along / r->l;
    } else {
      r->sin_phi = max_sin;
      r->cos_phi = max_cos;
    }
    r->norm = r->l * inv_optimal_fiber_length;
    r->active_force = max_force * a * ActiveValue(r->norm) * r->cos_phi;
    r->passive_force = max_force * PassiveValue(r->norm) * r->cos_phi;
    return true;
  }

  // The normalized curves' values (and, kSlope, the iteration slopes of At) on four lanes, the
  // same bits as ActiveValue / PassiveValue (SolveEvaluate for a Millard2012 curve, Active /
  // Passive / Tendon for Thelen2003, lane by lane: its exponentials are scalar).
  template <bool kSlope, int kCurve>
  ISOWRENCH_MUSCLE_INLINE void CurveLanes(const LaneV& x, LaneV& value, LaneV& slope) const {
    if (type == ForceModelType::kMillard2012) {
      const muscle::SmoothCurve& c = kCurve == 0 ? active : kCurve == 1 ? passive : tendon;
      c.Lanes<kSlope>(x, value, slope);
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
  ISOWRENCH_MUSCLE_INLINE unsigned RigidLanes(const LaneV& length, double a, LaneV& force,
                                              unsigned& slack_bits) const {
    const LaneV along = length - ISOWRENCH_MUSCLE_SPLAT(tendon_slack_length);
    LaneI slack = ~(LaneI)(along >= ISOWRENCH_MUSCLE_SPLAT(pennation_min_fiber_along_tendon));
    LaneV l;
    LaneSqrt(ISOWRENCH_MUSCLE_SPLAT(height * height) + along * along, l);
    slack |= ~(LaneI)(l > ISOWRENCH_MUSCLE_SPLAT(min_fiber));
    LaneV cos_phi = ISOWRENCH_MUSCLE_SPLAT(1.0);
    if (pennated) {
      const LaneI within = (ISOWRENCH_MUSCLE_SPLAT(height) / l) < ISOWRENCH_MUSCLE_SPLAT(max_sin);
      cos_phi = within ? along / l : ISOWRENCH_MUSCLE_SPLAT(max_cos);
    }
    // (slack lanes: any length inside the curves' range, not evaluated)
    const LaneV norm =
        slack ? ISOWRENCH_MUSCLE_SPLAT(1.0) : l * ISOWRENCH_MUSCLE_SPLAT(inv_optimal_fiber_length);
    LaneV fal, fpe, unused;
    CurveLanes<false, 0>(norm, fal, unused);
    CurveLanes<false, 1>(norm, fpe, unused);
    const LaneV f = ISOWRENCH_MUSCLE_SPLAT(max_force * a) * fal * cos_phi +
                    ISOWRENCH_MUSCLE_SPLAT(max_force) * fpe * cos_phi;
    force = slack ? ISOWRENCH_MUSCLE_SPLAT(0.0) : f;
    slack_bits = LaneBits(slack);
    return LaneBits(~(slack | (LaneI)(f <= ISOWRENCH_MUSCLE_SPLAT(1e150))));
  }

  MuscleForce Rigid(double length, double a) const {
    RigidFiber r;
    if (!RigidForce(length, a, &r)) return Slack(length, a);
    const double l = r.l, sin_phi = r.sin_phi, cos_phi = r.cos_phi;
    MuscleForce f;
    f.status = MuscleForceStatus::kEquilibrium;
    f.activation = a;
    f.fiber_length = l;
    f.pennation_angle = PennationAngle(sin_phi);
    const CurvePoint fal = Active(r.norm), fpe = Passive(r.norm);
    f.active_force = r.active_force;
    f.passive_force = r.passive_force;
    f.force = f.active_force + f.passive_force;
    // dF/dL = d(F_M cos phi)/dl * dl/dL, with l = sqrt(h^2 + (L - l_Ts)^2): dl/dL = cos phi.
    const double fiber = max_force * (a * fal.value + fpe.value);
    const double dfiber = max_force * (a * fal.slope + fpe.slope) * inv_optimal_fiber_length;
    const double dcos = sin_phi != 0.0 ? sin_phi * sin_phi / (l * cos_phi) : 0.0;
    f.stiffness = (dfiber * cos_phi + fiber * dcos) * cos_phi;
    f.fiber_length_slope = cos_phi;
    return f;
  }

  MuscleForce Equilibrium(const Sample& s, double l, double a, int iterations) const {
    MuscleForce f;
    f.status = MuscleForceStatus::kEquilibrium;
    f.activation = a;
    f.fiber_length = l;
    f.pennation_angle = PennationAngle(s.sin_phi);
    f.force = s.tendon_force;
    f.active_force = s.active * s.cos_phi;
    f.passive_force = s.passive * s.cos_phi;
    f.residual = s.residual;
    f.tendon_strain = s.norm_tendon_length - 1.0;
    f.iterations = iterations;
    // Implicit differentiation of r(l, L) = F_M(l) cos phi(l) - F_T(L - l cos phi(l)) = 0:
    // dl/dL = k_T / r_l with r_l = dF_MAT/dl + k_T / cos phi, and
    // dF/dL = k_T (1 - (dl_MAT/dl) dl/dL) = k_T dF_MAT/dl / r_l (the series stiffness).
    f.stiffness = s.slope != 0.0 ? s.tendon_stiffness * s.dfiber_along / s.slope : 0.0;
    f.fiber_length_slope = s.slope != 0.0 ? s.tendon_stiffness / s.slope : 0.0;
    return f;
  }

  // The compliant tendon's equilibrium: status kSlack (nothing else set),
  // kFiberAtMinimumLength (l = min_fiber, s its sample) or kEquilibrium (l, s).
  struct Solution {
    MuscleForceStatus status = MuscleForceStatus::kSlack;
    double l = 0.0;
    Step s;
    int iterations = 0;
    bool opensim_fails = false;
  };

  Solution Solve(double length, double a, double guess) const {
    Solution out;
    const double slack_along = length - tendon_slack_length;
    if (slack_along <= min_fiber_along_tendon) return out;
    // The fiber length where the tendon is exactly slack: the residual is >= 0 there (no
    // tendon force), and the equilibrium lies in [min_fiber, hi].
    double hi = std::sqrt(height * height + slack_along * slack_along);
    double lo = min_fiber;
    bool lo_negative = false;
    int iterations = 0;
    double x = guess;
    Step s;
    bool have_sample = false;
    if (!(guess > lo && guess < hi)) {
      // Cold start: OpenSim's own iteration picks the equilibrium (and says when it fails).
      if (!OpenSimIteration(length, a, &x, &s, &iterations) && !(x <= min_fiber)) {
        out.opensim_fails = true;  // OpenSim throws MuscleCannotEquilibrate here
        x = FiberLength(length, 1.01 * tendon_slack_length);
      } else {
        have_sample = true;  // s is the sample at x (OpenSim's last iterate)
      }
      const double clamped = std::clamp(x, lo, hi);
      have_sample = have_sample && clamped == x;
      x = clamped;
    }
    // Bracketed Newton (Numerical Recipes' rtsafe): a Newton step when it stays inside
    // [lo, hi] and at least halves the step before the last one, bisection otherwise, so the
    // bracket shrinks geometrically even where Newton's method crawls (an exponential passive
    // curve far from its root).
    if (!have_sample) s = Iterate(x, length, a);
    double step_before = hi - lo, step = step_before;
    for (int i = 0; i < 200; ++i) {
      if (std::abs(s.residual) <= tolerance) break;
      if (s.residual < 0) {
        lo = x;
        lo_negative = true;
      } else {
        hi = x;
      }
      if (hi - lo <= 2 * kSimTKEps * hi) break;  // bracket at rounding level
      double next = x - s.residual / s.slope;
      const bool slow = std::abs(next - x) > 0.5 * std::abs(step_before);
      step_before = step;
      if (!(next > lo && next < hi) || slow) {
        if (!lo_negative) {
          // Does the fiber want to be shorter than its minimum length?
          const Step low = Iterate(min_fiber, length, a);
          ++iterations;
          if (low.residual >= 0) {
            out.status = MuscleForceStatus::kFiberAtMinimumLength;
            out.l = min_fiber;
            out.s = low;
            out.iterations = iterations;
            return out;
          }
          lo_negative = true;
        }
        next = 0.5 * (lo + hi);
      }
      step = next - x;
      x = next;
      s = Iterate(x, length, a);
      ++iterations;
    }
    out.status = !lo_negative && x <= min_fiber && s.residual > tolerance
                     ? MuscleForceStatus::kFiberAtMinimumLength
                     : MuscleForceStatus::kEquilibrium;
    out.l = x;
    out.s = s;
    out.iterations = iterations;
    return out;
  }

  MuscleForce Compliant(double length, double a, double guess) const {
    const Solution solution = Solve(length, a, guess);
    if (solution.status == MuscleForceStatus::kSlack) return Slack(length, a);
    // The solve's sample again with the curves' exact slopes (the same values, bit for bit):
    // the stiffness and the fiber-length slope reported.
    const Sample s = At<true>(solution.l, length, a);
    if (solution.status == MuscleForceStatus::kFiberAtMinimumLength) {
      MuscleForce f = Equilibrium(s, min_fiber, a, solution.iterations);
      f.status = MuscleForceStatus::kFiberAtMinimumLength;
      f.active_force = 0.0;
      f.passive_force = 0.0;
      f.stiffness = s.tendon_stiffness;  // the fiber is held: dF/dL = k_T
      f.fiber_length_slope = 0.0;
      f.opensim_gives_no_number = solution.opensim_fails;
      return f;
    }
    MuscleForce f = Equilibrium(s, solution.l, a, solution.iterations);
    f.opensim_gives_no_number = solution.opensim_fails;
    return f;
  }

  // Evaluate(length, a).force and .status for a model with fast_tension (a in [0, 1], length
  // checked): the same computation without the fields the engine does not read. Returns false
  // where Evaluate's check of its fields would have to decide (a force or fiber force beyond
  // 1e150 N, or not a number): the caller runs Evaluate.
  bool Tension(double length, double a, double* force, MuscleForceStatus* status) const {
    constexpr double kLarge = 1e150;
    if (rigid) {
      RigidFiber r;
      if (!RigidForce(length, a, &r)) {
        *force = 0.0;
        *status = MuscleForceStatus::kSlack;
        return true;
      }
      *force = r.active_force + r.passive_force;
      *status = MuscleForceStatus::kEquilibrium;
      // (both parts are >= 0: their sum bounds each; NaN fails, as an infinite fiber length
      // gives: cos(phi) = (L - l_Ts) / l = 0 times an infinite curve value)
      return *force <= kLarge;
    }
    if (!(length <= std::numeric_limits<double>::max())) return false;  // (Evaluate: none)
    const Solution solution = Solve(length, a, 0.0);
    *status = solution.status;
    if (solution.status == MuscleForceStatus::kSlack) {
      *force = 0.0;
      return true;
    }
    *force = solution.s.tendon_force;
    return std::abs(solution.s.tendon_force) <= kLarge &&
           std::abs(solution.s.fiber_along) <= kLarge && solution.l <= kLarge;
  }
};

const char* ForceModelName(ForceModelType type) {
  switch (type) {
    case ForceModelType::kConstant: return "constant";
    case ForceModelType::kThelen2003: return "thelen2003";
    case ForceModelType::kMillard2012: return "millard2012";
  }
  return "?";
}

ForceModelType ParseForceModel(const std::string& name) {
  for (ForceModelType t :
       {ForceModelType::kConstant, ForceModelType::kThelen2003, ForceModelType::kMillard2012}) {
    if (name == ForceModelName(t)) return t;
  }
  throw Error("unknown force model '" + name + "' (known: constant, thelen2003, millard2012)");
}

const char* MuscleForceStatusName(MuscleForceStatus status) {
  switch (status) {
    case MuscleForceStatus::kEquilibrium: return "equilibrium";
    case MuscleForceStatus::kSlack: return "slack";
    case MuscleForceStatus::kFiberAtMinimumLength: return "fiber at minimum length";
    case MuscleForceStatus::kNoEquilibrium: return "no equilibrium";
  }
  return "?";
}

MuscleForceModel::MuscleForceModel() : MuscleForceModel("muscle", 1.0, MuscleForceSpec{}) {}

MuscleForceModel::MuscleForceModel(const std::string& muscle, double max_force,
                                   const MuscleForceSpec& spec) {
  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.muscle = muscle;
  m.type = spec.model;
  const std::string who = "muscle '" + muscle + "'";
  auto fail = [&](const std::string& what) { throw Error(who + ": " + what); };
  if (!(max_force > 0.0) || !std::isfinite(max_force)) {
    fail("max_force " + MuscleNumber(max_force) + " N must be > 0");
  }
  m.max_force = max_force;
  m.tolerance = kEquilibriumRelativeTolerance * max_force;
  if (spec.model == ForceModelType::kConstant) {
    impl_ = impl;
    return;
  }
  const bool thelen = spec.model == ForceModelType::kThelen2003;
  const char* model = thelen ? "Thelen2003Muscle" : "Millard2012EquilibriumMuscle";
  auto finite = [&](const char* name, double v, const char* unit) {
    if (!std::isfinite(v))
      fail(std::string(name) + " " + MuscleNumber(v) + unit + " is not finite");
  };
  finite("optimal_fiber_length", spec.optimal_fiber_length, " m");
  finite("tendon_slack_length", spec.tendon_slack_length, " m");
  finite("pennation_angle_at_optimal", spec.pennation_angle_at_optimal, " rad");
  finite("maximum_pennation_angle", spec.maximum_pennation_angle, " rad");
  finite("minimum_activation", spec.minimum_activation, "");
  finite("fiber_damping", spec.fiber_damping, "");

  // MuscleFixedWidthPennationModel::extendFinalizeFromProperties.
  const double ofl = spec.optimal_fiber_length;
  if (!(ofl > 0)) {
    fail("optimal_fiber_length " + MuscleNumber(ofl) +
         " m must be > 0 (OpenSim MuscleFixedWidthPennationModel)");
  }
  const double pen = spec.pennation_angle_at_optimal;
  if (pen < 0 || pen > M_PI / 2.0 - kSignificantReal) {
    fail("pennation_angle_at_optimal " + MuscleNumber(pen) +
         " rad must be in [0, pi/2) (OpenSim MuscleFixedWidthPennationModel)");
  }
  const double max_pen = spec.maximum_pennation_angle;
  if (max_pen < 0 || max_pen > M_PI / 2.0) {
    fail("maximum_pennation_angle " + MuscleNumber(max_pen) +
         " rad must be in [0, pi/2] (OpenSim MuscleFixedWidthPennationModel)");
  }
  if (spec.tendon_slack_length < 0) {
    fail("tendon_slack_length " + MuscleNumber(spec.tendon_slack_length) + " m must be >= 0");
  }
  // MuscleFirstOrderActivationDynamicModel::extendFinalizeFromProperties.
  const double min_act = spec.minimum_activation;
  if (min_act < 0 || min_act > 1.0 - kSignificantReal) {
    fail("minimum_activation " + MuscleNumber(min_act) +
         " must be in [0, 1) (OpenSim MuscleFirstOrderActivationDynamicModel)");
  }
  m.optimal_fiber_length = ofl;
  m.inv_optimal_fiber_length = 1.0 / ofl;
  m.tendon_slack_length = spec.tendon_slack_length;
  m.inv_tendon_slack_length = spec.tendon_slack_length > 0 ? 1.0 / spec.tendon_slack_length : 0.0;
  m.force_per_optimal_length = max_force * m.inv_optimal_fiber_length;
  m.force_per_tendon_slack_length = max_force * m.inv_tendon_slack_length;
  const double height = ofl * std::sin(pen);  // m_parallelogramHeight
  m.pennated = pen > kSimTKEps;
  m.height = m.pennated ? height : 0.0;
  m.max_pennation = max_pen;
  m.max_sin = std::sin(max_pen);
  m.max_cos = std::cos(max_pen);
  m.pennation_min_fiber = max_pen > kSignificantReal ? height / m.max_sin : 0.01 * ofl;
  m.pennation_min_fiber_along_tendon = m.pennation_min_fiber * m.max_cos;
  m.opensim_tolerance = std::max(1e-8 * max_force, kSignificantReal * 10);

  const bool rigid_requested = spec.ignore_tendon_compliance;
  if (thelen) {
    // Thelen2003Muscle::extendFinalizeFromProperties.
    const Thelen2003CurveSpec& t = spec.thelen;
    for (const auto& [name, v] :
         {std::pair<const char*, double>{"FmaxTendonStrain", t.FmaxTendonStrain},
          {"FmaxMuscleStrain", t.FmaxMuscleStrain},
          {"KshapeActive", t.KshapeActive},
          {"KshapePassive", t.KshapePassive}}) {
      if (!(v > 0) || !std::isfinite(v)) {
        fail(std::string(name) + " " + MuscleNumber(v) + " must be > 0 (OpenSim Thelen2003Muscle)");
      }
    }
    if (min_act < 0.01) {
      fail("minimum_activation " + MuscleNumber(min_act) +
           " must be >= 0.01 (OpenSim Thelen2003Muscle)");
    }
    m.min_activation = min_act;
    m.kshape_active = t.KshapeActive;
    m.passive_rate = t.KshapePassive / t.FmaxMuscleStrain;
    m.passive_scale = 1.0 / (std::exp(t.KshapePassive) - 1.0);
    const double e3 = std::exp(3.0);
    m.toe_strain = (99.0 * t.FmaxTendonStrain * e3) / (166.0 * e3 - 67.0);
    m.linear_slope = 0.67 / (t.FmaxTendonStrain - m.toe_strain);
    m.toe_scale = 0.33 / (e3 - 1.0);
    m.toe_rate = 3.0 / m.toe_strain;
    m.min_fiber = m.pennation_min_fiber;  // Thelen2003Muscle::getMinimumFiberLength
    m.min_fiber_along_tendon = m.pennation_min_fiber_along_tendon;
    m.opensim_max_iterations = 20;  // computeInitialFiberEquilibrium
    m.clamp_initial_guess = false;
    if (rigid_requested) {
      m.limitation =
          "ignore_tendon_compliance is not implemented for Thelen2003Muscle in OpenSim (the "
          "model is refused: ActivationFiberLengthMuscle::extendAddToSystem); isowrench "
          "computes the rigid tendon";
    }
  } else {
    // Millard2012EquilibriumMuscle::extendFinalizeFromProperties.
    const bool damped = spec.fiber_damping >= kMinNonzeroDamping;
    double ylow = spec.active_force_length.minimum_value;
    if (!rigid_requested && !damped) {
      if (min_act < 0.01) {
        fail("minimum_activation " + MuscleNumber(min_act) +
             " must be >= 0.01 with a compliant tendon and fiber_damping " +
             MuscleNumber(spec.fiber_damping) +
             " < 0.001 (OpenSim Millard2012EquilibriumMuscle, classic Hill model)");
      }
      if (ylow < 0.1) ylow = 0.1;  // "Parameter update for classic Hill model"
    } else if (ylow > 0.0) {
      ylow = 0.0;  // "Parameter update for the damped-model"
    }
    m.min_activation = min_act;
    m.active = muscle::ActiveForceLengthCurve(spec.active_force_length, ylow, muscle);
    m.passive = muscle::FiberForceLengthCurve(spec.fiber_force_length, muscle);
    m.tendon = muscle::TendonForceLengthCurve(spec.tendon_force_length, muscle);
    m.min_fiber = std::max(kSignificantReal,
                           std::max(spec.active_force_length.min_norm_active_fiber_length * ofl,
                                    m.pennation_min_fiber));
    double sin_phi = 0.0, cos_phi = 1.0;
    m.Pennation(m.min_fiber, &sin_phi, &cos_phi);
    m.min_fiber_along_tendon = m.min_fiber * cos_phi;
    m.opensim_max_iterations = 200;  // computeFiberEquilibrium
    m.clamp_initial_guess = true;
  }
  m.rigid = rigid_requested;
  if (!rigid_requested && !(spec.tendon_slack_length > 0)) {
    m.rigid = true;
    m.limitation = std::string("tendon_slack_length is 0 with a compliant tendon: OpenSim's ") +
                   model +
                   " equilibrium divides by it and fails (no force); isowrench computes the "
                   "rigid-tendon limit (a tendon of zero length)";
  }
  // A bound of the curves' slopes (per unit normalized length): Thelen2003's exponentials and
  // line, or four times the largest slope on 256 points of each Millard2012 curve (a corner's
  // slope lies between its ends' slopes).
  double slope_bound = 1.0;
  if (thelen) {
    slope_bound += m.passive_rate * (1.0 + m.passive_scale) + 2.0 / m.kshape_active +
                   m.linear_slope + m.toe_rate * m.toe_scale * std::exp(3.0);
  } else {
    for (const muscle::SmoothCurve* c : {&m.active, &m.passive, &m.tendon}) {
      for (int k = 0; k <= 256; ++k) {
        const double x = c->x0() + (c->x1() - c->x0()) * k / 256.0;
        slope_bound = std::max(slope_bound, 4.0 * std::abs(c->Evaluate(x).slope));
      }
    }
  }
  const double scale =
      max_force * slope_bound * (1.0 + m.inv_optimal_fiber_length + m.inv_tendon_slack_length);
  m.fast_tension = std::isfinite(scale) && scale <= 1e100;
  impl_ = impl;
}

MuscleForce MuscleForceModel::Evaluate(double length, double activation,
                                       double fiber_length_guess) const {
  const Impl& m = *impl_;
  if (!(activation >= 0.0 && activation <= 1.0)) {
    throw Error("muscle '" + m.muscle + "': activation " + MuscleNumber(activation) +
                " is outside [0, 1]");
  }
  if (m.type == ForceModelType::kConstant) {
    MuscleForce f;
    f.status = MuscleForceStatus::kEquilibrium;
    f.activation = activation;
    f.force = f.active_force = activation * m.max_force;
    return f;
  }
  MuscleForce f;
  if (!(length > 0.0) || !std::isfinite(length)) {
    f.status = MuscleForceStatus::kNoEquilibrium;
    f.activation = activation;
    return f;
  }
  const double a = std::max(activation, m.min_activation);  // clampActivation
  f = m.rigid ? m.Rigid(length, a) : m.Compliant(length, a, fiber_length_guess);
  f.opensim_gives_no_number = f.opensim_gives_no_number || !m.limitation.empty();
  const double fields[] = {f.force,        f.active_force,       f.passive_force, f.stiffness,
                           f.fiber_length, f.fiber_length_slope, f.tendon_strain, f.residual};
  for (double v : fields) {
    if (!std::isfinite(v)) {  // an exponential curve overflowed: no number to give
      const bool no_number = f.opensim_gives_no_number;
      f = MuscleForce{};
      f.status = MuscleForceStatus::kNoEquilibrium;
      f.activation = a;
      f.opensim_gives_no_number = no_number;
      break;
    }
  }
  return f;
}

double MuscleForceModel::Tension(double length, double activation,
                                 MuscleForceStatus* status) const {
  const Impl& m = *impl_;
  if (m.fast_tension && activation >= 0.0 && activation <= 1.0 && length > 0.0) {
    double force = 0.0;
    if (m.Tension(length, std::max(activation, m.min_activation), &force, status)) return force;
  }
  const MuscleForce f = Evaluate(length, activation);
  *status = f.status;
  return f.force;
}

namespace {

// MuscleForceModel::Tension4 (the clones: a free function).
ISOWRENCH_MUSCLE_LANES void TensionLanes(const MuscleForceModel& model,
                                         const MuscleForceModel::Impl& m, const double* length,
                                         double activation, double* force,
                                         MuscleForceStatus* status) {
  unsigned scalar = 0xf;
  if (m.fast_tension && m.type != ForceModelType::kConstant && activation >= 0.0 &&
      activation <= 1.0 && m.rigid) {
    const double a = std::max(activation, m.min_activation);
    LaneV L;
    std::memcpy(&L, length, sizeof L);
    LaneV f;
    unsigned slack = 0;
    scalar = m.RigidLanes(L, a, f, slack) | LaneBits(~(LaneI)(L > ISOWRENCH_MUSCLE_SPLAT(0.0)));
    std::memcpy(force, &f, sizeof f);
    for (int l = 0; l < 4; ++l) {
      status[l] = (slack >> l) & 1 ? MuscleForceStatus::kSlack : MuscleForceStatus::kEquilibrium;
    }
  }
  for (int l = 0; scalar != 0 && l < 4; ++l) {
    if (scalar & (1u << l)) force[l] = model.Tension(length[l], activation, &status[l]);
  }
}

}  // namespace

void MuscleForceModel::Tension4(const double length[4], double activation, double force[4],
                                MuscleForceStatus status[4]) const {
  TensionLanes(*this, *impl_, length, activation, force, status);
}

CurvePoint MuscleForceModel::ActiveForceLength(double x) const { return impl_->Active(x); }
CurvePoint MuscleForceModel::PassiveForceLength(double x) const { return impl_->Passive(x); }
CurvePoint MuscleForceModel::TendonForceLength(double x) const { return impl_->Tendon(x); }
const std::string& MuscleForceModel::muscle() const { return impl_->muscle; }
ForceModelType MuscleForceModel::type() const { return impl_->type; }
double MuscleForceModel::max_force() const { return impl_->max_force; }
bool MuscleForceModel::rigid_tendon() const { return impl_->rigid; }
double MuscleForceModel::minimum_fiber_length() const { return impl_->min_fiber; }
double MuscleForceModel::equilibrium_tolerance() const { return impl_->tolerance; }
double MuscleForceModel::minimum_activation() const { return impl_->min_activation; }
const std::string& MuscleForceModel::opensim_limitation() const { return impl_->limitation; }

// ---- spec equality -------------------------------------------------------------------------

bool ActiveForceLengthCurveSpec::operator==(const ActiveForceLengthCurveSpec& o) const {
  return min_norm_active_fiber_length == o.min_norm_active_fiber_length &&
         transition_norm_fiber_length == o.transition_norm_fiber_length &&
         max_norm_active_fiber_length == o.max_norm_active_fiber_length &&
         shallow_ascending_slope == o.shallow_ascending_slope && minimum_value == o.minimum_value;
}

bool FiberForceLengthCurveSpec::operator==(const FiberForceLengthCurveSpec& o) const {
  return strain_at_zero_force == o.strain_at_zero_force &&
         strain_at_one_norm_force == o.strain_at_one_norm_force &&
         stiffness_at_low_force == o.stiffness_at_low_force &&
         stiffness_at_one_norm_force == o.stiffness_at_one_norm_force && curviness == o.curviness;
}

bool TendonForceLengthCurveSpec::operator==(const TendonForceLengthCurveSpec& o) const {
  return strain_at_one_norm_force == o.strain_at_one_norm_force &&
         stiffness_at_one_norm_force == o.stiffness_at_one_norm_force &&
         norm_force_at_toe_end == o.norm_force_at_toe_end && curviness == o.curviness;
}

bool Thelen2003CurveSpec::operator==(const Thelen2003CurveSpec& o) const {
  return FmaxTendonStrain == o.FmaxTendonStrain && FmaxMuscleStrain == o.FmaxMuscleStrain &&
         KshapeActive == o.KshapeActive && KshapePassive == o.KshapePassive;
}

bool MuscleForceSpec::operator==(const MuscleForceSpec& o) const {
  return model == o.model && optimal_fiber_length == o.optimal_fiber_length &&
         tendon_slack_length == o.tendon_slack_length &&
         pennation_angle_at_optimal == o.pennation_angle_at_optimal &&
         maximum_pennation_angle == o.maximum_pennation_angle &&
         minimum_activation == o.minimum_activation &&
         ignore_tendon_compliance == o.ignore_tendon_compliance &&
         fiber_damping == o.fiber_damping && active_force_length == o.active_force_length &&
         fiber_force_length == o.fiber_force_length &&
         tendon_force_length == o.tendon_force_length && thelen == o.thelen;
}

}  // namespace isowrench
