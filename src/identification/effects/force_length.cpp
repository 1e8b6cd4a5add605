// Effect force_length:MUSCLE: the muscle's force-length operating point is off its model's: the
// optimal fiber length and the tendon slack length scaled (issue 28 item 4).

#include "identification/effect_type.hpp"
#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

/// Search range of both scale factors (x): a fiber or tendon length off by more than a factor of
/// two is not a misestimate but another muscle.
constexpr double kForceLengthLower = 0.5;
constexpr double kForceLengthUpper = 2.0;

constexpr const char* kForceLengthSummary =
    "MUSCLE's force-length operating point differs from its force model's (thelen2003 or "
    "millard2012): optimal_fiber_length x l_o_scale and tendon_slack_length x l_Ts_scale. The "
    "force F(L_MT, a) of every posture moves along the muscle's own active and passive curves "
    "(the equilibrium is solved again), so the wrench changes with the muscle's length, not by a "
    "common factor. l_Ts_scale exists only for a tendon_slack_length > 0 (a tendon of length 0 "
    "scales to 0: the rigid-tendon limit stays). Written into the augmented URDF's "
    "optimal_fiber_length and tendon_slack_length. A constant-force muscle has no force-length "
    "curve: naming it is an error.";

class ForceLength final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"force_length",
            "force_length:MUSCLE (MUSCLE with a thelen2003 or millard2012 force model)",
            EffectStage::kModel,
            kForceLengthSummary,
            "l_o_scale (optimal_fiber_length factor, x, log10, 0.5 to 2), l_Ts_scale "
            "(tendon_slack_length factor, x, log10, 0.5 to 2; only when tendon_slack_length > 0)",
            "force_scale:MUSCLE (a common factor; the curve's slope over the postures tells them "
            "apart); attachment:MUSCLE:* and joint_offset of a coordinate it crosses (they move "
            "its length too); trial_force (factors that follow the length are refused there)"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>& muscles) const override {
    std::vector<Effect> out;
    for (const MuscleSpec& m : model.description().muscles) {
      if (!Wanted(muscles, m.name) || m.force.model == ForceModelType::kConstant) continue;
      Effect e;
      e.kind = "force_length";
      e.id = "force_length:" + m.name;
      e.muscle = m.name;
      e.stage = EffectStage::kModel;
      e.description = "muscle " + m.name + " (" + ForceModelName(m.force.model) +
                      ") optimal fiber length" +
                      (m.force.tendon_slack_length > 0 ? " and tendon slack length" : "") +
                      " differ from the model by a factor";
      e.parameters.push_back(
          LogParameter("l_o_scale", "x", 1.0, 1.0, kForceLengthLower, kForceLengthUpper));
      if (m.force.tendon_slack_length > 0) {
        e.parameters.push_back(
            LogParameter("l_Ts_scale", "x", 1.0, 1.0, kForceLengthLower, kForceLengthUpper));
      }
      e.confounders = {"force_scale:" + m.name, "attachment:" + m.name + ":",
                       "joint_offset:", "trial_force"};
      out.push_back(e);
    }
    return out;
  }
  std::string WhyNotCandidate(const Model& model, const std::string& id) const override {
    const std::string name = id.substr(id.find(':') + 1);
    for (const MuscleSpec& m : model.description().muscles) {
      if (m.name == name && m.force.model == ForceModelType::kConstant) return ConstantMuscle(m);
    }
    return "";
  }
  /// l_Ts_scale is held at 1 when the trials cannot tell it from l_o_scale: over a small range
  /// of muscle lengths both shift the force along the same curve (their whitened sensitivities
  /// at the nominal model correlated beyond options.max_correlation, the fit's identifiability
  /// limit), or it changes nothing.
  std::string RestrictToData(const Model& model, const std::vector<Trial>& trials,
                             const std::vector<Vector6d>& wrench, const FitOptions& options,
                             Effect* effect) const override {
    if (effect->parameters.size() < 2) return "";
    std::vector<Trial> own;
    for (const Trial& t : trials) {
      if (t.muscle == effect->muscle) own.push_back(t);
    }
    // A sample is enough to judge the correlation (evenly spaced: the file order is kept).
    constexpr size_t kMaxTrials = 2000;
    if (own.size() > kMaxTrials) {
      std::vector<Trial> sample;
      for (size_t i = 0; i < kMaxTrials; ++i) sample.push_back(own[i * own.size() / kMaxTrials]);
      own = std::move(sample);
    }
    (void)wrench;
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(2, 2);
    try {
      std::vector<Prediction> p;
      for (const std::vector<double>& v :
           {std::vector<double>{1.0, 1.0}, {1.001, 1.0}, {1.0, 1.001}})
        p.push_back(PredictTrials(ApplyEffects(model.description(), {{*effect, v}}), own));
      for (size_t k = 0; k < own.size(); ++k) {
        if (!p[0].ok[k] || !p[1].ok[k] || !p[2].ok[k]) continue;
        for (int c = 0; c < 6; ++c) {
          const double w = Weight(own[k], c, options);
          const Eigen::Vector2d g(w * (p[1].wrench[k][c] - p[0].wrench[k][c]),
                                  w * (p[2].wrench[k][c] - p[0].wrench[k][c]));
          G += g * g.transpose();
        }
      }
    } catch (const Error&) {
      return "";  // the fit will say what cannot be evaluated
    }
    const double d = std::sqrt(G(0, 0) * G(1, 1));
    const double r = d > 0 ? -G(0, 1) / d : 1.0;  // correlation of the two estimates
    if (!(G(1, 1) > 0) || !(std::abs(r) <= options.max_correlation)) {
      effect->parameters.resize(1);
      effect->description += " (l_Ts_scale held at 1)";
      return effect->id + ": l_Ts_scale held at 1: over these trials' lengths a tendon slack " +
             "length change acts like an optimal fiber length change (estimates correlated, r = " +
             util::FormatNumber(r, 4) + "), so l_o_scale stands for both; `isowrench design " +
             "--effects " + effect->id + "` picks postures that separate them";
    }
    return "";
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    for (MuscleSpec& muscle : m->description.muscles) {
      if (muscle.name != e.muscle) continue;
      if (muscle.force.model == ForceModelType::kConstant)
        throw Error("effect '" + e.id + "': " + ConstantMuscle(muscle));
      muscle.force.optimal_fiber_length *= v[0];
      if (v.size() > 1) muscle.force.tendon_slack_length *= v[1];
      return;
    }
    throw Error("effect '" + e.id + "': unknown muscle '" + e.muscle + "'");
  }

 private:
  static std::string ConstantMuscle(const MuscleSpec& m) {
    return "muscle '" + m.name +
           "' has the constant force model (F = a x max_force at every length): it has no "
           "force-length curve to shift. force_length needs a thelen2003 or millard2012 muscle "
           "(URDF model=\"...\" with optimal_fiber_length and tendon_slack_length, or `isowrench "
           "import` of an .osim), and not --force-model constant";
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_force_length() { return std::make_unique<ForceLength>(); }

}  // namespace isowrench::ident
