#pragma once
/// @file
/// Muscle force models: the isometric (zero-velocity) tension of a musculotendon unit at a given
/// musculotendon path length L_MT and activation a, as OpenSim 4.x computes it for its
/// Thelen2003Muscle and Millard2012EquilibriumMuscle (rigid and compliant tendon), plus the
/// `constant` model (F = a * max_force, the paper's and isowrench's original model).
///
/// Two layers, as Model and Data elsewhere:
///   - MuscleForceSpec: the editable description (OpenSim's property names and defaults), part of
///     MuscleSpec (model.hpp), read from .osim (import) and URDF (<isowrench:muscle model=...>);
///   - MuscleForceModel: built once from a spec (validated, every curve coefficient precomputed),
///     immutable, cheap to evaluate (no allocation, no exception on the numeric path).
///
/// Every formula, its source in opensim-core and the statuses are in docs/muscle.md.
///
///   isowrench::MuscleForceSpec spec;
///   spec.model = isowrench::ForceModelType::kMillard2012;
///   spec.optimal_fiber_length = 0.0293;  // m
///   spec.tendon_slack_length = 0.0064;   // m
///   isowrench::MuscleForceModel gp("GP", /*max_force=*/2.35, spec);
///   isowrench::MuscleForce f = gp.Evaluate(/*L_MT=*/0.036, /*activation=*/1.0);
///   // f.force (N), f.active_force, f.passive_force, f.stiffness (dF/dL_MT, N/m), f.status

#include <memory>
#include <optional>
#include <string>

namespace isowrench {

/// Which force model a muscle uses.
enum class ForceModelType {
  /// F = a * max_force at every length (no curves, no clamp): the paper's model and the
  /// default of a URDF muscle without a `model` attribute.
  kConstant,
  /// OpenSim Thelen2003Muscle: Thelen's exponential/Gaussian curves, compliant tendon.
  kThelen2003,
  /// OpenSim Millard2012EquilibriumMuscle: quintic Bezier curves; rigid tendon when
  /// MuscleForceSpec::ignore_tendon_compliance, compliant otherwise.
  kMillard2012,
};

/// "constant", "thelen2003" or "millard2012" (the URDF `model` attribute).
const char* ForceModelName(ForceModelType type);

/// Inverse of ForceModelName. @throws Error naming the text and listing the known names.
ForceModelType ParseForceModel(const std::string& name);

/// OpenSim ActiveForceLengthCurve (Millard2012) properties: normalized fiber lengths l/l_o and
/// dimensionless values. Defaults are OpenSim 4.x's (ActiveForceLengthCurve::constructProperties).
struct ActiveForceLengthCurveSpec {
  double min_norm_active_fiber_length = 0.47 - 0.0259;  ///< where the curve reaches minimum_value
  double transition_norm_fiber_length = 0.73;           ///< end of the steep ascending limb
  double max_norm_active_fiber_length =
      1.8123;                               ///< where the descending limb reaches minimum_value
  double shallow_ascending_slope = 0.8616;  ///< slope of the shallow ascending limb (1 / (l/l_o))
  /// Floor of the curve. Millard2012 overrides it (Millard2012EquilibriumMuscle::
  /// extendFinalizeFromProperties): 0 with fiber damping or a rigid tendon, at least 0.1 for an
  /// undamped compliant tendon; MuscleForceModel applies the same rule.
  double minimum_value = 0.1;
  /// Field-wise equality (optional properties compare set-ness and value).
  bool operator==(const ActiveForceLengthCurveSpec& o) const;
  bool operator!=(const ActiveForceLengthCurveSpec& o) const { return !(*this == o); }
};

/// OpenSim FiberForceLengthCurve (Millard2012 passive fiber) properties. Strains are
/// l/l_o - 1. The three optional properties are all set or all empty (OpenSim's rule); when empty
/// OpenSim uses stiffness_at_low_force 0.2, stiffness_at_one_norm_force 2/(e1 - e0) and
/// curviness 0.75 (FiberForceLengthCurve::ensureCurveUpToDate).
struct FiberForceLengthCurveSpec {
  double strain_at_zero_force = 0.0;                  ///< the passive force starts here
  double strain_at_one_norm_force = 0.7;              ///< the passive force is max_force here
  std::optional<double> stiffness_at_low_force;       ///< normalized (1 / strain)
  std::optional<double> stiffness_at_one_norm_force;  ///< normalized (1 / strain)
  std::optional<double> curviness;                    ///< 0..1
  /// Field-wise equality (optional properties compare set-ness and value).
  bool operator==(const FiberForceLengthCurveSpec& o) const;
  bool operator!=(const FiberForceLengthCurveSpec& o) const { return !(*this == o); }
};

/// OpenSim TendonForceLengthCurve (Millard2012) properties. Strain is l_T/l_Ts - 1. The three
/// optional properties are all set or all empty; when empty OpenSim uses
/// stiffness_at_one_norm_force 1.375/strain_at_one_norm_force, norm_force_at_toe_end 2/3 and
/// curviness 0.5 (TendonForceLengthCurve::ensureCurveUpToDate).
struct TendonForceLengthCurveSpec {
  double strain_at_one_norm_force = 0.049;  ///< the tendon carries max_force at this strain
  std::optional<double> stiffness_at_one_norm_force;  ///< normalized (1 / strain)
  std::optional<double> norm_force_at_toe_end;        ///< 0..1, end of the toe region
  std::optional<double> curviness;                    ///< 0..1
  /// Field-wise equality (optional properties compare set-ness and value).
  bool operator==(const TendonForceLengthCurveSpec& o) const;
  bool operator!=(const TendonForceLengthCurveSpec& o) const { return !(*this == o); }
};

/// Thelen2003Muscle curve properties (OpenSim names; defaults of Thelen2003Muscle::
/// constructProperties). The force-velocity properties (Af, Flen, fv_linear_extrap_threshold)
/// only act at non-zero fiber velocity and are not part of the isometric model.
struct Thelen2003CurveSpec {
  double FmaxTendonStrain = 0.04;  ///< tendon strain at max_force
  double FmaxMuscleStrain = 0.6;   ///< passive fiber strain at max_force
  double KshapeActive = 0.45;      ///< Gaussian shape of the active force-length curve
  double KshapePassive = 5.0;      ///< exponential shape of the passive force-length curve
  /// Field-wise equality (optional properties compare set-ness and value).
  bool operator==(const Thelen2003CurveSpec& o) const;
  bool operator!=(const Thelen2003CurveSpec& o) const { return !(*this == o); }
};

/// A muscle's force model and its parameters (OpenSim property names; lengths in m, angles in
/// rad). The muscle's max_force (MuscleSpec) is OpenSim's max_isometric_force.
struct MuscleForceSpec {
  /// The model; kConstant ignores every other field.
  ForceModelType model = ForceModelType::kConstant;
  double optimal_fiber_length = 0.0;  ///< m, > 0 (not used by kConstant)
  /// m, >= 0. 0 with a compliant tendon is a model OpenSim cannot evaluate (its equilibrium
  /// divides by it): isowrench then computes the rigid-tendon limit (see MuscleForceModel).
  double tendon_slack_length = 0.0;
  double pennation_angle_at_optimal = 0.0;              ///< rad, in [0, pi/2)
  double maximum_pennation_angle = 1.4706289056333368;  ///< rad, in [0, pi/2]; acos(0.1)
  /// Activation floor: OpenSim clamps the activation to [minimum_activation, 1] before the
  /// force is computed (MuscleFirstOrderActivationDynamicModel::clampActivation); Thelen2003
  /// needs >= 0.01.
  double minimum_activation = 0.01;
  /// Millard2012 only: rigid tendon (fiber length from the path length, no equilibrium).
  /// Thelen2003Muscle does not implement it in OpenSim (the model is refused there).
  bool ignore_tendon_compliance = false;
  /// Millard2012 only (1/s-normalized, OpenSim fiber_damping): at zero velocity it only decides
  /// the damped (>= 0.001) or classic Hill (< 0.001) variant, whose curve floors differ.
  double fiber_damping = 0.1;
  ActiveForceLengthCurveSpec active_force_length;  ///< Millard2012
  FiberForceLengthCurveSpec fiber_force_length;    ///< Millard2012
  TendonForceLengthCurveSpec tendon_force_length;  ///< Millard2012
  Thelen2003CurveSpec thelen;                      ///< Thelen2003
  /// Field-wise equality (optional properties compare set-ness and value).
  bool operator==(const MuscleForceSpec& o) const;
  bool operator!=(const MuscleForceSpec& o) const { return !(*this == o); }
};

/// What one force evaluation found.
enum class MuscleForceStatus {
  /// Fiber and tendon in equilibrium: |fiber force along the tendon - tendon force| <=
  /// MuscleForceModel::equilibrium_tolerance(), or the fiber length bracketed to rounding where
  /// forces far above max_force make that tolerance unreachable (rigid tendon: the fiber length
  /// follows from the path length and the force is the fiber's).
  kEquilibrium,
  /// The path is too short for tension: L_MT <= tendon slack length + the fiber's minimum length
  /// along the tendon. The fiber rests at its minimum length and the force is 0 (OpenSim: 0 too).
  kSlack,
  /// The fiber would have to be shorter than its minimum length (maximum pennation, or the
  /// active curve's minimum): OpenSim clamps it there and the force is the tendon's at that
  /// fiber length (Millard2012/Thelen2003 estimateMuscleFiberState / initMuscleState
  /// "Warning_FiberAtLowerBound"); active_force and passive_force are 0, as in OpenSim's
  /// MuscleDynamicsInfo of a clamped fiber.
  kFiberAtMinimumLength,
  /// No equilibrium: the path length is not finite or not positive, or the force it implies
  /// is not representable (an exponential curve overflowing at an absurd length). force is 0
  /// and is not a number to use.
  kNoEquilibrium,
};

/// "equilibrium", "slack", "fiber at minimum length", "no equilibrium".
const char* MuscleForceStatusName(MuscleForceStatus status);

/// Result of MuscleForceModel::Evaluate. Every field is finite.
struct MuscleForce {
  /// N, tension along the tendon (what the path transmits; OpenSim's actuation/tendon force).
  double force = 0.0;
  /// N, active fiber force projected on the tendon: max_force * a * f_L(l/l_o) * cos(phi).
  double active_force = 0.0;
  /// N, passive (elastic) fiber force projected on the tendon: max_force * f_PE * cos(phi).
  /// At equilibrium active_force + passive_force = force + residual.
  double passive_force = 0.0;
  /// N/m, dF/dL_MT at this length and activation (analytic, implicit differentiation of the
  /// equilibrium; 0 where the force is 0 or constant).
  double stiffness = 0.0;
  double fiber_length = 0.0;  ///< m (0 for kConstant)
  /// d fiber_length / dL_MT (dimensionless): with the previous fiber length it predicts a good
  /// Evaluate guess at a nearby length, fiber_length + fiber_length_slope * (L_new - L).
  double fiber_length_slope = 0.0;
  double pennation_angle = 0.0;  ///< rad
  /// Tendon strain l_T / l_Ts - 1 (0 for a rigid tendon and when tendon_slack_length is 0;
  /// negative when kSlack).
  double tendon_strain = 0.0;
  /// The activation the force was computed with: OpenSim's clamp of the requested activation
  /// to [minimum_activation, 1] (kConstant: the requested activation).
  double activation = 0.0;
  /// N, fiber force along the tendon minus tendon force at the returned fiber length (0 for a
  /// rigid tendon).
  double residual = 0.0;
  /// Newton/bisection iterations of the equilibrium solve (0 without one).
  int iterations = 0;
  MuscleForceStatus status = MuscleForceStatus::kNoEquilibrium;
  /// True when OpenSim itself gives no number here: the muscle is one OpenSim cannot evaluate
  /// (MuscleForceModel::opensim_limitation()), or, on a cold start (no fiber-length guess),
  /// OpenSim's own Newton iteration fails at this length (MuscleCannotEquilibrate) where the
  /// bracketed solve of isowrench finds the equilibrium.
  bool opensim_gives_no_number = false;
};

/// Value and slope of a normalized curve.
struct CurvePoint {
  double value = 0.0;
  double slope = 0.0;  ///< d value / d argument
};

/// A muscle's force model, compiled: parameters validated, OpenSim's parameter adjustments
/// applied, curve coefficients precomputed. Immutable; Evaluate allocates nothing and throws
/// only for an activation outside [0, 1]. Cheap to copy (shared state); thread-safe to share.
class MuscleForceModel {
 public:
  /// The constant model with max_force 1 N (a placeholder).
  MuscleForceModel();
  /// Validate `spec` (OpenSim's own checks, plus: lengths finite, tendon_slack_length >= 0)
  /// and precompute. `muscle` names the muscle in messages.
  /// @throws Error naming the muscle, the property and its value for anything OpenSim rejects
  ///         (MuscleFixedWidthPennationModel, MuscleFirstOrderActivationDynamicModel,
  ///         Thelen2003Muscle and Millard2012EquilibriumMuscle extendFinalizeFromProperties, the
  ///         curve classes and SmoothSegmentedFunctionFactory), or max_force not > 0.
  MuscleForceModel(const std::string& muscle, double max_force, const MuscleForceSpec& spec);

  /// The isometric force at musculotendon length `length` (m, the path length L_MT) and
  /// activation `activation` (in [0, 1]). Compliant tendons solve the zero-velocity
  /// fiber-tendon equilibrium. Without a guess (fiber_length_guess <= 0) the solve starts
  /// where OpenSim's does and follows OpenSim's Newton iteration (so it finds the equilibrium
  /// OpenSim finds where there are several), then polishes to equilibrium_tolerance() by a
  /// bracketed Newton iteration; with a guess (m, e.g. the previous posture's fiber_length) it
  /// runs the bracketed Newton iteration from there (fewer iterations; where the equilibrium is
  /// not unique it may find another one than a cold start).
  /// @throws Error naming the muscle and the value if activation is not in [0, 1].
  MuscleForce Evaluate(double length, double activation, double fiber_length_guess = 0.0) const;

  /// Evaluate(length, activation).force (N), bit for bit, with its status in *status, without
  /// the other fields (no stiffness, fiber-length slope, pennation angle): the engine's force
  /// stage. A compliant tendon starts cold (no guess), as Evaluate without one.
  /// @throws Error naming the muscle and the value if activation is not in [0, 1].
  double Tension(double length, double activation, MuscleForceStatus* status) const;

  /// Four lengths at once: force[l] = Tension(length[l], activation, &status[l]) for l = 0..3,
  /// bit for bit (the batch engine's force stage: the fiber, pennation, curves and equilibrium
  /// of the four lengths computed together on the lanes of one SIMD register where they take
  /// the common path, lane by lane by Tension where not).
  /// @throws Error naming the muscle and the value if activation is not in [0, 1].
  void Tension4(const double length[4], double activation, double force[4],
                MuscleForceStatus status[4]) const;

  /// n lengths at once (n >= 0): force[i] = Tension(length[i], activation, &status[i]) for
  /// i = 0..n-1, bit for bit (the batch engine's force stage over a block of postures: a
  /// compliant tendon's taut lengths are sorted and solved by Tension4 four neighbours at a
  /// time, so that the four lanes share curve segments and iteration counts more often; other
  /// models by Tension4 in the given order).
  /// @throws Error naming the muscle and the value if activation is not in [0, 1] (n > 0).
  void TensionBlock(const double* length, long n, double activation, double* force,
                    MuscleForceStatus* status) const;

  /// Active force-length multiplier f_L at normalized fiber length l/l_o (kConstant: 1, 0).
  CurvePoint ActiveForceLength(double norm_fiber_length) const;
  /// Passive fiber force-length multiplier f_PE at l/l_o (kConstant: 0, 0).
  CurvePoint PassiveForceLength(double norm_fiber_length) const;
  /// Tendon force-length multiplier f_SE at normalized tendon length l_T/l_Ts (kConstant: 0, 0).
  CurvePoint TendonForceLength(double norm_tendon_length) const;

  const std::string& muscle() const;
  ForceModelType type() const;
  double max_force() const;  ///< N
  /// True when the fiber length follows from the path length (ignore_tendon_compliance, or the
  /// rigid-tendon limit isowrench computes for a model OpenSim cannot evaluate).
  bool rigid_tendon() const;
  /// m: OpenSim's minimum fiber length (Millard2012: the largest of the active curve's
  /// minimum and the pennation model's; Thelen2003: the pennation model's). 0 for kConstant.
  double minimum_fiber_length() const;
  /// N: the equilibrium tolerance |residual| the solve reaches: 1e-13 * max_force.
  double equilibrium_tolerance() const;
  /// The activation floor in use after OpenSim's adjustments (kConstant: 0).
  double minimum_activation() const;
  /// Why OpenSim cannot evaluate this muscle and what isowrench computes instead ("" when
  /// OpenSim can), e.g. "tendon_slack_length is 0 with a compliant tendon: OpenSim's
  /// equilibrium divides by it and fails (no force); isowrench computes the rigid-tendon limit
  /// (a tendon of zero length)".
  const std::string& opensim_limitation() const;

  /// Opaque precomputed state. Not part of the stable API.
  struct Impl;

 private:
  std::shared_ptr<const Impl> impl_;
};

}  // namespace isowrench
