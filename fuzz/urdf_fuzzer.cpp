// libFuzzer harness: URDF text -> ReadUrdfString -> Model -> EvaluateWrench of every muscle at
// the nominal posture and at a posture read from the input's last bytes. isowrench::Error is
// the expected answer to bad input; any other exception, crash, sanitizer report or hang is a
// finding.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  isowrench::SetWarningHandler([](const std::string&) {});  // warnings are legal output
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return -1;  // URDFs are small; keeps executions fast
  std::string xml(reinterpret_cast<const char*>(data), size);
  try {
    isowrench::Model model(isowrench::ReadUrdfString(xml, "fuzz.urdf"));
    Eigen::VectorXd q = model.nominal_posture();
    for (int i = 0; i < model.muscle_count(); ++i) {
      isowrench::WrenchEvaluation e =
          isowrench::EvaluateWrench(model, q, model.muscle(i).name, 0.5);
      if (e.statics.ok() && !e.statics.wrench.allFinite()) __builtin_trap();  // "ok" must be finite
    }
    // A second posture from the input bytes (angles in [-pi, pi]).
    for (int j = 0; j < q.size(); ++j) {
      q[j] = (static_cast<double>(data[(size - 1 - j % size)]) - 128.0) / 128.0 * 3.14159;
    }
    for (int i = 0; i < model.muscle_count(); ++i) {
      isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(model, q, model.muscle(i).name);
      if (e.statics.ok() && !e.statics.wrench.allFinite()) __builtin_trap();
    }
  } catch (const isowrench::Error&) {
  }
  return 0;
}
