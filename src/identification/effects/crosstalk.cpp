// Effect crosstalk: the off-diagonal part of the transducer's calibration error, all 30 terms.

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>

#include "identification/effect_type.hpp"
#include "identification/identification_impl.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

/// Length that makes moments comparable with forces (m): the sum of the joint offsets and the
/// endpoint offset of the description (the limb's reach).
double ReachLength(const LimbDescription& d) {
  double length = d.transducer.endpoint.norm();
  for (const JointSpec& j : d.joints) length += j.origin.translation().norm();
  return length > 0 ? length : 1.0;
}

/// Search range of each normalised term (x): a calibration error of 100 % bounds any real one;
/// with the reach as the length a 20 mm lever error (SI) is 0.28 on the rat limb (reach 72 mm).
constexpr double kTermRange = 1.0;

/// A term's name: "<reading>_<source>", e.g. "mx_fy" = moment reading mx picks up force fy.
std::string TermName(int reading, int source) {
  return std::string(AxisName(reading)) + "_" + AxisName(source);
}

/// The (reading, source) axes of a term name; false when the name is not a term.
bool ParseTerm(const std::string& name, int* reading, int* source) {
  const size_t bar = name.find('_');
  if (bar == std::string::npos) return false;
  *reading = AxisIndex(name.substr(0, bar));
  *source = AxisIndex(name.substr(bar + 1));
  return *reading >= 0 && *source >= 0 && *reading != *source;
}

constexpr const char* kCrosstalkSummary =
    R"(The off-diagonal part of the transducer's calibration error: reading = D (I + E) D^-1 W, D = diag(1, 1, 1, L, L, L) with L the limb's reach (so moment and force terms are comparable), E with zero diagonal and all 30 off-diagonal terms free. The diagonal is gain:AXIS. E contains, to first order, a small rotation of the transducer axes (misalignment: E_ff = E_mm = -[r]x, the same skew part in the force and moment blocks, 3 directions) and a shift of the moment origin (sensor_origin: E_mf = -[d]x, the skew part of the moment-from-force block, 3 directions); the other 24 directions (the symmetric parts of the four blocks, the skew parts of E_ff and E_mm that differ, the skew part of E_fm and the symmetric part of E_mf) no other effect expresses. A smaller effect it contains wins when it explains the data (fewer parameters, lower BIC); crosstalk replaces misalignment or sensor_origin when it is added after them, and they cannot be added after it. Terms the measured wrenches cannot determine (a source axis the wrenches never vary along) are held at 0 and named in the report; `isowrench design --effects crosstalk` chooses postures that determine them.)";

class Crosstalk final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"crosstalk",
            "crosstalk",
            EffectStage::kMeasurement,
            kCrosstalkSummary,
            "30 terms READING_SOURCE (x, linear, -1 to 1, normalised by the reach), e.g. mx_fy",
            "misalignment and sensor_origin (contained to first order: replaced when crosstalk "
            "is added after them); gain: (the diagonal, a separate effect)"};
  }
  std::vector<Effect> Candidates(const Model&, const std::vector<std::string>&) const override {
    Effect e;
    e.kind = "crosstalk";
    e.id = "crosstalk";
    e.stage = EffectStage::kMeasurement;
    e.post_processing = true;
    e.description =
        "the transducer's calibration matrix has off-diagonal (crosstalk) terms, all 30";
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) {
        if (i != j) e.parameters.push_back(LinearParameter(TermName(i, j), "x", kTermRange));
      }
    }
    e.confounders = {"misalignment", "sensor_origin", "gain:"};
    e.contains = {"misalignment", "sensor_origin"};
    return {e};
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    const double length = ReachLength(m->description);
    Matrix6d c = Matrix6d::Identity();
    for (size_t k = 0; k < e.parameters.size(); ++k) {
      int i = -1, j = -1;
      if (!ParseTerm(e.parameters[k].name, &i, &j)) continue;
      const double di = i < 3 ? 1.0 : length, dj = j < 3 ? 1.0 : length;
      c(i, j) = di * v[k] / dj;
    }
    m->calibration = c * m->calibration;
  }

  /// Term (i, j) changes reading i of trial t by (d_i / d_j) W_j v: row i's terms are
  /// determined by the wrench components j != i. Per row, the standard error each term would
  /// have with the others of its row (whitened Gram matrix of those components, pseudo-inverse
  /// by SVD); the term with the largest is dropped until every one left is below a quarter of
  /// the search range (the fit's "not determined" rule).
  std::string RestrictToData(const Model& model, const std::vector<Trial>& trials,
                             const std::vector<Vector6d>& wrench, const FitOptions& options,
                             Effect* effect) const override {
    const double length = ReachLength(model.description());
    const double limit = 0.25 * 2.0 * kTermRange;
    std::vector<EffectParameter> kept;
    std::vector<std::string> dropped;
    for (int i = 0; i < 6; ++i) {
      std::vector<int> sources;
      for (const EffectParameter& p : effect->parameters) {
        int r = -1, s = -1;
        if (ParseTerm(p.name, &r, &s) && r == i) sources.push_back(s);
      }
      while (!sources.empty()) {
        const int k = static_cast<int>(sources.size());
        Eigen::MatrixXd G = Eigen::MatrixXd::Zero(k, k);
        for (size_t t = 0; t < trials.size() && t < wrench.size(); ++t) {
          const double w = Weight(trials[t], i, options) * (i < 3 ? 1.0 : length);
          Eigen::VectorXd g(k);
          for (int a = 0; a < k; ++a) {
            g[a] = w * wrench[t][sources[a]] / (sources[a] < 3 ? 1.0 : length);
          }
          G += g * g.transpose();
        }
        Eigen::JacobiSVD<Eigen::MatrixXd> svd(G, Eigen::ComputeFullV);
        const Eigen::VectorXd s = svd.singularValues();
        const Eigen::MatrixXd& V = svd.matrixV();
        // Standard error of term a: sqrt of the diagonal of G's pseudo-inverse; a direction with
        // a singular value below 1e-12 of the largest is undetermined (infinite error).
        int worst = -1;
        double worst_se = 0.0;
        for (int a = 0; a < k; ++a) {
          double variance = 0.0;
          for (int b = 0; b < k; ++b) {
            if (!(s[b] > 1e-12 * s[0])) {
              if (std::abs(V(a, b)) > 1e-9) variance = std::numeric_limits<double>::infinity();
              continue;
            }
            variance += V(a, b) * V(a, b) / s[b];
          }
          const double se = std::sqrt(variance);
          if (!(se <= worst_se) && !(se <= limit)) {
            worst = a;
            worst_se = se;
          }
        }
        if (worst < 0) break;
        dropped.push_back(TermName(i, sources[worst]));
        sources.erase(sources.begin() + worst);
      }
      for (int s : sources) {
        for (const EffectParameter& p : effect->parameters) {
          if (p.name == TermName(i, s)) kept.push_back(p);
        }
      }
    }
    if (dropped.empty()) return "";
    const size_t total = kept.size() + dropped.size();
    effect->parameters = kept;
    effect->description += " (" + std::to_string(kept.size()) + " of the " + std::to_string(total) +
                           " terms: the others are not identifiable here)";
    return "crosstalk: " + std::to_string(dropped.size()) + " of " + std::to_string(total) +
           " terms are not identifiable from these postures and muscles (the measured wrenches "
           "do not vary along their source axes independently of the others; each would have a "
           "standard error above " +
           util::FormatNumber(limit, 3) +
           " of the normalised range) and are held at 0: " + util::Join(dropped, ", ") +
           "; `isowrench design MODEL --effects crosstalk` chooses postures that determine them";
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_crosstalk() { return std::make_unique<Crosstalk>(); }

}  // namespace isowrench::ident
