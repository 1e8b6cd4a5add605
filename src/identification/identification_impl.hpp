#pragma once
// Private helpers shared by the identification sources.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "isowrench/identification.hpp"

namespace isowrench::ident {

/// Reproducible random numbers independent of the standard library's distributions.
class Random {
 public:
  explicit Random(unsigned long long seed) : state_(seed) {}
  std::uint64_t Next();                 ///< splitmix64
  double Uniform();                     ///< [0, 1)
  double Uniform(double lo, double hi); ///< [lo, hi)
  double Normal();                      ///< standard normal (Box-Muller)

 private:
  std::uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// Internal (least-squares) value of a parameter from its user value and back.
double ToInternal(const EffectParameter& p, double user);
double ToUser(const EffectParameter& p, double internal);

/// Weight (1/sd) of component c of a trial.
double Weight(const Trial& trial, int c, const FitOptions& options);

/// Map a trial's joint names onto a model's columns (index per trial entry, -1 = absent).
std::vector<int> JointMap(const Model& model, const std::vector<std::string>& names);

/// Maps trials onto a model's posture vector and muscle index, caching the last mapping.
class TrialMapper {
 public:
  explicit TrialMapper(const Model& model);
  /// Fill q (model columns; joints the trial lacks at 0) and return the muscle index.
  /// @throws Error for unknown muscles or unmappable postures.
  int Map(const Trial& trial, Eigen::VectorXd* q);

 private:
  const Model* model_;
  const std::vector<std::string>* last_names_ = nullptr;
  std::vector<int> map_;
  std::string last_muscle_;
  int muscle_index_ = -1;
};

/// Prediction on a subset of trials (indices), without rebuilding anything but a workspace.
void PredictSubset(const Model& model, const std::vector<Trial>& trials, const std::vector<int>& subset,
                   const Vector6d& sensor_offset, std::vector<Vector6d>* wrench, std::vector<bool>* ok,
                   std::string* message);

/// Two effects that cannot both be in one model (they edit the same thing).
std::string ConflictKey(const Effect& effect);

}  // namespace isowrench::ident
