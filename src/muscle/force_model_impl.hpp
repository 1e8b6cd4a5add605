#pragma once
// Private: MuscleForceModel's compiled state (muscle_force.cpp: construction, Evaluate, Tension;
// muscle_lanes.cpp: Tension4, the batch force stage's four lanes).

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "isowrench/muscle.hpp"
#include "muscle/smooth_curve.hpp"

#if defined(__GNUC__)
#define ISOWRENCH_MUSCLE_INLINE inline __attribute__((always_inline))
#define ISOWRENCH_MUSCLE_LAMBDA_INLINE __attribute__((always_inline))
#else
#define ISOWRENCH_MUSCLE_INLINE inline
#define ISOWRENCH_MUSCLE_LAMBDA_INLINE
#endif

namespace isowrench {
namespace muscle {
// SimTK constants (SimTKcommon/Scalar.h): Eps, SignificantReal = Eps^(7/8), SqrtEps.
inline constexpr double kSimTKEps = std::numeric_limits<double>::epsilon();
inline const double kSignificantReal = std::pow(kSimTKEps, 0.875);
inline const double kSqrtEps = std::sqrt(kSimTKEps);
// The equilibrium tolerance of isowrench's solve, relative to max_force (OpenSim stops at
// 1e-8 * max_force; the bracketed Newton polish continues to this).
inline constexpr double kEquilibriumRelativeTolerance = 1e-13;
// Millard2012EquilibriumMuscle.cpp MIN_NONZERO_DAMPING_COEFFICIENT.
inline constexpr double kMinNonzeroDamping = 0.001;
}  // namespace muscle
using muscle::kEquilibriumRelativeTolerance;
using muscle::kMinNonzeroDamping;
using muscle::kSignificantReal;
using muscle::kSimTKEps;
using muscle::kSqrtEps;

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
  bool pennated = false;        // pennation_angle_at_optimal > Eps
  double height = 0.0;          // parallelogram height l_o sin(phi_o)
  double height_squared = 0.0;  // height * height (the same product, computed once)
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
    return along >= pennation_min_fiber_along_tendon ? FiberRoot(height_squared + along * along)
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

  // std::sqrt(x) for x >= 0 or NaN, without its errno branch (sqrtsd, correctly rounded as
  // std::sqrt and the lanes' sqrtpd).
  static double FiberRoot(double x) {
#if defined(__SSE2__)
    return _mm_cvtsd_f64(_mm_sqrt_sd(_mm_set_sd(x), _mm_set_sd(x)));
#else
    return std::sqrt(x);
#endif
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
    r->l = FiberRoot(height_squared + along * along);
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

  // The batch force stage's lanes (src/muscle/muscle_lanes.cpp, MuscleForceModel::Tension4).
  // The numbers the compliant lanes use in every sample, splatted once (SplatLaneNumbers, at
  // the end of construction): memory operands in muscle_lanes.cpp, not a broadcast per use.
  struct LaneNumbers {
    muscle::LaneDoubles one{}, half{}, nan{}, sqrt_eps{}, significant_real{}, rounding{};
    muscle::LaneDoubles min_fiber{}, max_sin{}, max_cos{}, height{}, pennation_min_fiber{};
    muscle::LaneDoubles tolerance{}, max_force{}, inv_optimal_fiber_length{};
    muscle::LaneDoubles inv_tendon_slack_length{}, force_per_optimal_length{};
    muscle::LaneDoubles force_per_tendon_slack_length{};
    muscle::LaneMasks magnitude{};  // all bits of a double but the sign
  };
  LaneNumbers lane;
  void SplatLaneNumbers() {
    auto splat = [](double v) { return muscle::LaneDoubles{v, v, v, v}; };
    lane.one = splat(1.0);
    lane.half = splat(0.5);
    lane.nan = splat(std::numeric_limits<double>::quiet_NaN());
    lane.sqrt_eps = splat(kSqrtEps);
    lane.significant_real = splat(kSignificantReal);
    lane.rounding = splat(2 * kSimTKEps);
    lane.min_fiber = splat(min_fiber);
    lane.max_sin = splat(max_sin);
    lane.max_cos = splat(max_cos);
    lane.height = splat(height);
    lane.pennation_min_fiber = splat(pennation_min_fiber);
    lane.tolerance = splat(tolerance);
    lane.max_force = splat(max_force);
    lane.inv_optimal_fiber_length = splat(inv_optimal_fiber_length);
    lane.inv_tendon_slack_length = splat(inv_tendon_slack_length);
    lane.force_per_optimal_length = splat(force_per_optimal_length);
    lane.force_per_tendon_slack_length = splat(force_per_tendon_slack_length);
    const long long bits = 0x7fffffffffffffffLL;
    lane.magnitude = muscle::LaneMasks{bits, bits, bits, bits};
  }

  // kAvx2: compiled for AVX2 (the curves' gathers, one-instruction lane masks).
  template <bool kSlope, int kCurve, bool kAvx2>
  void CurveLanes(const muscle::LaneDoubles& x, muscle::LaneDoubles& value,
                  muscle::LaneDoubles& slope) const;
  template <bool kAvx2>
  unsigned RigidLanes(const muscle::LaneDoubles& length, double a, muscle::LaneDoubles& force,
                      unsigned& slack_bits) const;
  template <bool kAvx2>
  void IterateLanes(const muscle::LaneDoubles& l, const muscle::LaneDoubles& length,
                    const muscle::LaneDoubles& a, const muscle::LaneDoubles& max_force_a,
                    muscle::LaneDoubles& residual, muscle::LaneDoubles& slope,
                    muscle::LaneDoubles& tendon_force, muscle::LaneDoubles& fiber_along) const;
  template <bool kAvx2>
  unsigned CompliantLanes(const muscle::LaneDoubles& length, double a, muscle::LaneDoubles& force,
                          unsigned& slack_bits) const;

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
    double hi = FiberRoot(height_squared + slack_along * slack_along);
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

}  // namespace isowrench
