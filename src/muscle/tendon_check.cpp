// A tendon slack length longer than the musculotendon path at every posture (issue 28 item 7):
// the muscle is slack wherever the limb goes and can never pull; a warning when the Model is
// built (once per model and muscle in a process).

#include "muscle/tendon_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <utility>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/posture.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

/// Postures sampled for a muscle that is slack at the nominal posture (after the 2 n + 1 along
/// the coordinate axes).
constexpr int kTendonCheckRandomPostures = 256;
constexpr double kTendonCheckPi = 3.14159265358979323846;

/// The range one coordinate is sampled over: its own when finite, else nominal +- 180° (rad)
/// or +- 0.1 m.
void TendonCheckRange(const Model& model, int c, double nominal, double* lo, double* hi) {
  const CoordinateSpec& s = model.coordinate(c);
  const double reach = s.type == JointType::kRevolute ? kTendonCheckPi : 0.1;
  *lo = std::isfinite(s.lower) ? s.lower : nominal - reach;
  *hi = std::isfinite(s.upper) ? s.upper : nominal + reach;
}

/// splitmix64 in [0, 1): the same postures on every run.
double TendonCheckUniform(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
}

/// True the first time (model, muscle) is seen in this process: the warning is given once, and a
/// fit that rebuilds the model per evaluation neither repeats it nor searches again.
bool TendonCheckFirstTime(const std::string& model, const std::string& muscle) {
  static std::mutex mutex;
  static std::set<std::pair<std::string, std::string>> seen;
  std::lock_guard<std::mutex> lock(mutex);
  return seen.emplace(model, muscle).second;
}

}  // namespace

void CheckTendonsCanStretch(const Model& model) {
  Data data(model);
  const Eigen::VectorXd nominal = model.nominal_posture();
  const int n = model.dof_count();
  for (int i = 0; i < model.muscle_count(); ++i) {
    const MuscleSpec& m = model.muscle(i);
    const double slack = m.force.tendon_slack_length;
    if (m.force.model == ForceModelType::kConstant || !(slack > 0)) continue;
    double longest = -1.0;
    Eigen::VectorXd at = nominal;
    int checked = 0;
    auto length_at = [&](const Eigen::VectorXd& q) {
      ++checked;
      try {
        const double l = ComputeMuscleTorque(model, data, q, i, 1.0).length;
        if (l > longest) {
          longest = l;
          at = q;
        }
      } catch (const Error&) {
        // Coincident path points at this posture: no length here; the other postures decide.
      }
      return longest > slack;
    };
    if (length_at(nominal) || !TendonCheckFirstTime(model.name(), m.name)) continue;
    bool stretched = false;
    for (int c = 0; c < n && !stretched; ++c) {
      double lo = 0, hi = 0;
      TendonCheckRange(model, c, nominal[c], &lo, &hi);
      for (double v : {lo, hi, 0.5 * (lo + hi)}) {
        Eigen::VectorXd q = nominal;
        q[c] = v;
        if ((stretched = length_at(q))) break;
      }
    }
    std::uint64_t state = 0x7E4D0 + static_cast<std::uint64_t>(i);
    for (int k = 0; k < kTendonCheckRandomPostures && !stretched; ++k) {
      Eigen::VectorXd q(n);
      for (int c = 0; c < n; ++c) {
        double lo = 0, hi = 0;
        TendonCheckRange(model, c, nominal[c], &lo, &hi);
        q[c] = lo + (hi - lo) * TendonCheckUniform(&state);
      }
      stretched = length_at(q);
    }
    if (stretched) continue;
    Warn("muscle '" + m.name + "': tendon_slack_length " + util::FormatNumber(slack * 1e3, 4) +
         " mm is longer than its musculotendon path at every posture checked (" +
         std::to_string(checked) + " within the coordinates' ranges; longest path " +
         (longest >= 0 ? util::FormatNumber(longest * 1e3, 4) + " mm at " + FormatPosture(model, at)
                       : std::string("not evaluable")) +
         "): the tendon is always slack and the muscle never pulls (force 0, status slack; " +
         "OpenSim gives 0 too)");
  }
}

}  // namespace isowrench
