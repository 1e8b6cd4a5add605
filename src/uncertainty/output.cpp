// An uncertainty result as JSON (isowrench uncertainty --json, Python Model.uncertainty).

#include <cmath>
#include <nlohmann/json.hpp>

#include "isowrench/posture.hpp"
#include "isowrench/uncertainty.hpp"

namespace isowrench {

namespace {

// JSON never holds -0 or a non-finite number (null instead).
nlohmann::ordered_json UncertaintyNumber(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v == 0.0 ? 0.0 : v;
}

}  // namespace

std::string UncertaintyJson(const UncertaintyResult& r, const Model& model) {
  nlohmann::ordered_json postures = nlohmann::ordered_json::array();
  for (const PostureUncertainty& p : r.postures) {
    nlohmann::ordered_json posture = nlohmann::ordered_json::object();
    for (int c = 0; c < model.dof_count(); ++c) {
      posture[model.joint_names()[static_cast<size_t>(c)]] =
          UncertaintyNumber(JointValueToUserUnits(model.joint(c).type, p.posture[c]));
    }
    nlohmann::ordered_json quantities = nlohmann::ordered_json::object();
    for (int q = 0; q < kUncertaintyQuantities; ++q) {
      const QuantityStatistics& s = p.statistics[static_cast<size_t>(q)];
      const bool defined = s.count > 0;
      quantities[UncertaintyQuantityName(q)] = {
          {"unit", UncertaintyQuantityUnit(q)},
          {"nominal",
           p.nominal_defined() ? UncertaintyNumber(p.nominal[static_cast<size_t>(q)]) : nullptr},
          {"mean", defined ? UncertaintyNumber(s.mean) : nullptr},
          {"sd", defined ? UncertaintyNumber(s.sd) : nullptr},
          {"p2.5", defined ? UncertaintyNumber(s.percentiles[0]) : nullptr},
          {"p50", defined ? UncertaintyNumber(s.percentiles[1]) : nullptr},
          {"p95", defined ? UncertaintyNumber(s.percentiles[2]) : nullptr},
          {"p97.5", defined ? UncertaintyNumber(s.percentiles[3]) : nullptr},
          {"count", s.count}};
    }
    nlohmann::ordered_json first = nlohmann::ordered_json::object(),
                           total = nlohmann::ordered_json::object();
    for (size_t g = 0; g < r.groups.size() && g < p.sobol.size(); ++g) {
      nlohmann::ordered_json f = nlohmann::ordered_json::object(),
                             t = nlohmann::ordered_json::object();
      for (int q = 0; q < kUncertaintyQuantities; ++q) {
        if (!UncertaintySobolQuantity(q)) continue;
        f[UncertaintyQuantityName(q)] = UncertaintyNumber(p.sobol[g][static_cast<size_t>(q)].first);
        t[UncertaintyQuantityName(q)] = UncertaintyNumber(p.sobol[g][static_cast<size_t>(q)].total);
      }
      first[r.groups[g]] = f;
      total[r.groups[g]] = t;
    }
    const double n = static_cast<double>(std::max<long>(p.samples, 1));
    postures.push_back({{"posture", posture},
                        {"posture_units", "deg (mm for prismatic coordinates)"},
                        {"nominal_status", StatusName(p.nominal_status)},
                        {"counts",
                         {{"samples", p.samples},
                          {"valid", p.valid},
                          {"no_equilibrium", p.no_equilibrium},
                          {"invalid", p.invalid},
                          {"small_motion_failed", p.small_motion_failed}}},
                        {"fractions",
                         {{"no_equilibrium", static_cast<double>(p.no_equilibrium) / n},
                          {"invalid", static_cast<double>(p.invalid) / n},
                          {"small_motion_failed", static_cast<double>(p.small_motion_failed) / n}}},
                        {"quantities", quantities},
                        {"sobol", r.sobol ? nlohmann::ordered_json{{"rows", p.sobol_rows},
                                                                   {"first", first},
                                                                   {"total", total}}
                                          : nlohmann::ordered_json(nullptr)}});
  }
  nlohmann::ordered_json j = {
      {"model", r.model},
      {"muscle", r.muscle},
      {"samples", r.samples},
      {"evaluations", r.evaluations},
      {"seed", r.seed},
      {"block_samples", kUncertaintyBlockSamples},
      {"sobol",
       r.sobol
           ? nlohmann::ordered_json{{"first_order", "Saltelli 2010: mean f_B (f_ABi - f_A) / V"},
                                    {"total", "Jansen 1999: mean (f_A - f_ABi)^2 / (2 V)"}}
           : nlohmann::ordered_json(nullptr)},
      {"groups", r.groups},
      {"percentiles",
       {{"levels", {2.5, 50, 95, 97.5}},
        {"method", r.percentile_method},
        {"exact", r.exact_percentiles}}},
      {"wrench",
       "reading of the transducer (misalignment and calibration applied): transducer axes; "
       "world axes = R_W_T at the nominal posture x reading; moment about the endpoint"},
      {"postures", postures},
      {"notes", r.notes},
      {"seconds", r.seconds}};
  return j.dump(2);
}

}  // namespace isowrench
