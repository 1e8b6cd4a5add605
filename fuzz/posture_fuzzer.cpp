// libFuzzer harness: "--posture" text -> ApplyPostureAssignments on the 5-dof rat hindlimb.
// isowrench::Error is the expected answer to bad input; an accepted posture must be finite.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/posture.hpp"

namespace {
const isowrench::Model* g_model = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  isowrench::SetWarningHandler([](const std::string&) {});
  g_model = new isowrench::Model(isowrench::Model::FromUrdfFile(ISOWRENCH_FUZZ_URDF));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 4096) return -1;
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    std::vector<std::string> warnings;  // the plausibility checks run too (PostureWarnings)
    Eigen::VectorXd q =
        isowrench::ApplyPostureAssignments(*g_model, g_model->nominal_posture(), text, &warnings);
    if (!q.allFinite()) __builtin_trap();
  } catch (const isowrench::Error&) {
  }
  return 0;
}
