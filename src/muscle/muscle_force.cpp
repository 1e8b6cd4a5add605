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
#include <limits>

#include "isowrench/error.hpp"
#include "isowrench/muscle.hpp"
#include "muscle/force_model_impl.hpp"
#include "muscle/smooth_curve.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

std::string MuscleNumber(double v) { return util::FormatNumber(v, 6); }

}  // namespace

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
  m.height_squared = m.height * m.height;
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
  m.SplatLaneNumbers();
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
