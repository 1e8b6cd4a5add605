// Uncertainty specs: the JSON spec file, and a fit's parameters and covariance (fit --json).

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"
#include "isowrench/uncertainty.hpp"

namespace isowrench {

const char* DistributionName(InputDistribution distribution) {
  switch (distribution) {
    case InputDistribution::kNormal: return "normal";
    case InputDistribution::kLogNormal: return "lognormal";
    case InputDistribution::kUniform: return "uniform";
    case InputDistribution::kLogUniform: return "loguniform";
  }
  return "?";
}

namespace {

InputDistribution SpecDistribution(const std::string& text, const std::string& where) {
  for (InputDistribution d : {InputDistribution::kNormal, InputDistribution::kLogNormal,
                              InputDistribution::kUniform, InputDistribution::kLogUniform}) {
    if (text == DistributionName(d)) return d;
  }
  throw Error(where + ": unknown distribution '" + text + "'" +
              DidYouMean(text, {"normal", "lognormal", "uniform", "loguniform"}) +
              " (normal, lognormal, uniform, loguniform)");
}

double SpecNumber(const nlohmann::json& value, const std::string& where) {
  if (!value.is_number()) throw Error(where + " must be a number, got " + value.dump());
  const double v = value.get<double>();
  if (!std::isfinite(v)) throw Error(where + " must be finite");
  return v;
}

std::string ReadWholeFile(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(std::string("cannot read ") + what + " '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

UncertaintySpec ParseUncertaintySpec(const std::string& json_text, const std::string& source) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(source + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw Error(source + ": the spec must be a JSON object {\"inputs\": [...]}");
  for (const auto& [key, value] : j.items()) {
    if (key != "inputs" && key != "comment") {
      throw Error(source + ": unknown field '" + key + "'" +
                  DidYouMean(key, {"inputs", "comment"}) + " (fields: inputs, comment)");
    }
  }
  if (!j.contains("inputs") || !j["inputs"].is_array())
    throw Error(source + ": needs \"inputs\": [ ... ] (a list of inputs)");
  UncertaintySpec spec;
  if (j.contains("fit")) {
    try {
      const nlohmann::json& f = j["fit"];
      spec.has_fit = true;
      spec.fit.source = f.at("source").get<std::string>();
      spec.fit.model = f.at("model").get<std::string>();
      spec.fit.names = f.at("names").get<std::vector<std::string>>();
      spec.fit.log10 = f.at("log10").get<std::vector<bool>>();
      spec.fit.notes = f.value("notes", std::vector<std::string>{});
      const std::vector<double> mean = f.at("mean").get<std::vector<double>>();
      const std::vector<std::vector<double>> cov =
          f.at("covariance").get<std::vector<std::vector<double>>>();
      const Eigen::Index n = static_cast<Eigen::Index>(spec.fit.names.size());
      if (static_cast<Eigen::Index>(mean.size()) != n ||
          static_cast<Eigen::Index>(cov.size()) != n ||
          static_cast<Eigen::Index>(spec.fit.log10.size()) != n)
        throw Error(source + ": fit: names, log10, mean and covariance differ in size");
      spec.fit.mean = Eigen::Map<const Eigen::VectorXd>(mean.data(), n);
      spec.fit.covariance.resize(n, n);
      for (Eigen::Index a = 0; a < n; ++a) {
        if (static_cast<Eigen::Index>(cov[static_cast<size_t>(a)].size()) != n)
          throw Error(source + ": fit: the covariance is not square");
        for (Eigen::Index b = 0; b < n; ++b)
          spec.fit.covariance(a, b) = cov[static_cast<size_t>(a)][static_cast<size_t>(b)];
      }
    } catch (const nlohmann::json::exception& e) {
      throw Error(source + ": fit: " + e.what());
    }
  }
  int index = 0;
  for (const nlohmann::json& item : j["inputs"]) {
    const std::string where = source + ": inputs[" + std::to_string(index++) + "]";
    if (!item.is_object()) throw Error(where + " must be an object {\"name\": ..., ...}");
    UncertainInput input;
    bool has_distribution = false;
    for (const auto& [key, value] : item.items()) {
      const std::string field = where + "." + key;
      if (key == "name") {
        if (!value.is_string()) throw Error(field + " must be a string");
        input.name = value.get<std::string>();
      } else if (key == "distribution") {
        if (!value.is_string()) throw Error(field + " must be a string");
        input.distribution = SpecDistribution(value.get<std::string>(), field);
        has_distribution = true;
      } else if (key == "sd") {
        if (value.is_array()) {
          for (size_t k = 0; k < value.size(); ++k)
            input.sd.push_back(SpecNumber(value[k], field + "[" + std::to_string(k) + "]"));
        } else {
          input.sd.push_back(SpecNumber(value, field));
        }
      } else if (key == "lower") {
        input.lower = SpecNumber(value, field);
      } else if (key == "upper") {
        input.upper = SpecNumber(value, field);
      } else if (key != "comment") {
        throw Error(field + ": unknown field" +
                    DidYouMean(key, {"name", "distribution", "sd", "lower", "upper", "comment"}) +
                    " (fields: name, distribution, sd, lower, upper, comment)");
      }
    }
    if (input.name.empty()) throw Error(where + " has no \"name\"");
    if (!has_distribution && input.sd.empty() && item.contains("lower")) {
      input.distribution = InputDistribution::kUniform;
    }
    spec.inputs.push_back(std::move(input));
  }
  return spec;
}

UncertainInput ParseUncertainInput(const std::string& text, const std::string& option) {
  const std::string what = option + " '" + text + "'";
  const size_t eq = text.rfind('=');
  if (eq == std::string::npos || eq == 0) {
    throw Error(what +
                " is not NAME=DISTRIBUTION:PARAMETERS (e.g. angle:hip_rz=normal:2, "
                "base_stiffness=loguniform:1e4:1e7)");
  }
  UncertainInput input;
  input.name = util::Trim(text.substr(0, eq));
  const std::vector<std::string> parts = util::Split(text.substr(eq + 1), ":");
  if (parts.size() < 2) throw Error(what + ": needs DISTRIBUTION:PARAMETERS after '='");
  input.distribution = SpecDistribution(util::Trim(parts[0]), what);
  if (input.distribution == InputDistribution::kUniform ||
      input.distribution == InputDistribution::kLogUniform) {
    if (parts.size() != 3) throw Error(what + ": " + parts[0] + " needs LOWER:UPPER");
    input.lower = util::ParseDoubleOrThrow(parts[1], what + " lower");
    input.upper = util::ParseDoubleOrThrow(parts[2], what + " upper");
  } else {
    if (parts.size() != 2) throw Error(what + ": " + parts[0] + " needs SD (or SD,SD,SD)");
    for (const std::string& item : util::Split(parts[1], ","))
      input.sd.push_back(util::ParseDoubleOrThrow(item, what + " sd"));
  }
  return input;
}

std::string UncertaintySpecJson(const UncertaintySpec& spec) {
  nlohmann::ordered_json inputs = nlohmann::ordered_json::array();
  for (const UncertainInput& in : spec.inputs) {
    nlohmann::ordered_json item = {{"name", in.name},
                                   {"distribution", DistributionName(in.distribution)}};
    if (!in.sd.empty()) item["sd"] = in.sd;
    if (in.distribution == InputDistribution::kUniform ||
        in.distribution == InputDistribution::kLogUniform) {
      item["lower"] = in.lower;
      item["upper"] = in.upper;
    }
    inputs.push_back(item);
  }
  nlohmann::ordered_json j = {{"inputs", inputs}};
  if (spec.has_fit) {
    std::vector<std::vector<double>> cov;
    for (Eigen::Index a = 0; a < spec.fit.covariance.rows(); ++a) {
      cov.emplace_back();
      for (Eigen::Index b = 0; b < spec.fit.covariance.cols(); ++b)
        cov.back().push_back(spec.fit.covariance(a, b));
    }
    j["fit"] = {{"source", spec.fit.source},
                {"model", spec.fit.model},
                {"names", spec.fit.names},
                {"log10", spec.fit.log10},
                {"mean", std::vector<double>(spec.fit.mean.data(),
                                             spec.fit.mean.data() + spec.fit.mean.size())},
                {"covariance", cov},
                {"notes", spec.fit.notes}};
  }
  return j.dump();  // nlohmann prints doubles to round-trip exactly
}

UncertaintySpec ReadUncertaintySpecFile(const std::string& path) {
  return ParseUncertaintySpec(ReadWholeFile(path, "uncertainty spec"), path);
}

namespace {

// Effect kinds --from-fit can sample (their parameters map onto the study's targets).
bool SupportedFitEffect(const std::string& id) {
  static const char* kPrefixes[] = {
      "base_isotropic", "base_per_axis", "transducer_soft:", "transducer_anisotropy",
      "force_scale:",   "gain:",         "crosstalk",        "misalignment",
      "sensor_origin",  "sensor_offset", "joint_offset:",    "attachment:"};
  for (const char* p : kPrefixes) {
    if (id.rfind(p, 0) == 0) return true;
  }
  return false;
}

}  // namespace

FitUncertainty ReadFitUncertainty(const std::string& path, const Model& model) {
  const std::string text = ReadWholeFile(path, "fit JSON");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("model") || !j.contains("chosen") || !j["chosen"].is_array())
    throw Error(path + ": not the output of `isowrench fit --json` (no \"model\" and \"chosen\")");
  FitUncertainty fit;
  fit.source = path;
  fit.model = j["model"].is_string() ? j["model"].get<std::string>() : "";
  if (fit.model != model.name()) {
    throw Error(path + " is a fit of model '" + fit.model + "', not of '" + model.name() +
                "': its parameters do not apply to this model");
  }
  std::vector<double> sd;
  for (const nlohmann::json& effect : j["chosen"]) {
    const std::string id = effect.value("effect", std::string());
    if (!SupportedFitEffect(id)) {
      throw Error(
          path + ": effect '" + id +
          "' cannot be sampled by `uncertainty` yet (supported: base_isotropic, "
          "base_per_axis, transducer_soft, transducer_anisotropy, force_scale, gain, "
          "crosstalk, misalignment, sensor_origin, sensor_offset, joint_offset, attachment)");
    }
    for (const nlohmann::json& p : effect.at("parameters")) {
      const std::string name = id + "." + p.at("name").get<std::string>();
      const double value = p.at("value").get<double>();
      const double log_se = p.value("log10_standard_error", 0.0);
      const double se = p.value("standard_error", 0.0);
      // The fit JSON gives log10_standard_error > 0 exactly for parameters fitted as log10.
      const bool log10 = log_se > 0.0;
      if (log10 && !(value > 0))
        throw Error(path + ": " + name + " = " + std::to_string(value) +
                    " is fitted in log10 but not positive");
      const double s = log10 ? log_se : se;
      if (!std::isfinite(s) || s < 0 || !std::isfinite(value))
        throw Error(path + ": " + name + " has no finite standard error");
      fit.names.push_back(name);
      fit.log10.push_back(log10);
      sd.push_back(s);
      fit.mean.conservativeResize(static_cast<Eigen::Index>(fit.names.size()));
      fit.mean[fit.mean.size() - 1] = log10 ? std::log10(value) : value;
    }
  }
  const Eigen::Index n = static_cast<Eigen::Index>(fit.names.size());
  Eigen::MatrixXd correlation = Eigen::MatrixXd::Identity(n, n);
  if (j.contains("correlations") && j["correlations"].is_object() &&
      j["correlations"].contains("parameters")) {
    const std::vector<std::string> labels =
        j["correlations"]["parameters"].get<std::vector<std::string>>();
    const nlohmann::json& matrix = j["correlations"]["matrix"];
    std::vector<Eigen::Index> where(labels.size(), -1);
    for (size_t a = 0; a < labels.size(); ++a) {
      for (Eigen::Index k = 0; k < n; ++k)
        if (fit.names[static_cast<size_t>(k)] == labels[a]) where[a] = k;
    }
    for (size_t a = 0; a < labels.size(); ++a) {
      for (size_t b = 0; b < labels.size(); ++b) {
        if (where[a] < 0 || where[b] < 0) continue;
        correlation(where[a], where[b]) = matrix.at(a).at(b).get<double>();
      }
    }
  }
  Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(sd.data(), n);
  fit.covariance = s.asDiagonal() * correlation * s.asDiagonal();
  fit.covariance = 0.5 * (fit.covariance + fit.covariance.transpose()).eval();
  if (n == 0) fit.notes.push_back(path + ": the fit chose no effect: nothing to sample from it");
  return fit;
}

}  // namespace isowrench
