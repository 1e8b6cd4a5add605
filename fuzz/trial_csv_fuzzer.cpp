// libFuzzer harness: trial CSV text -> TrialReader (RFC 4180 records, header checks, range
// checks) against the 5-dof rat hindlimb. isowrench::Error is the expected answer to bad input.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"

namespace {
const isowrench::Model* g_model = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  isowrench::SetWarningHandler([](const std::string&) {});
  g_model = new isowrench::Model(isowrench::Model::FromUrdfFile(ISOWRENCH_FUZZ_URDF));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    isowrench::TrialReader reader(*g_model, in, "fuzz.csv");
    isowrench::Trial t;
    while (reader.Next(&t)) {
      // Whatever the reader accepts is a finite, plausible measurement.
      if (!t.q.allFinite() || !t.wrench.allFinite() || !(t.activation >= 0 && t.activation <= 1) ||
          t.wrench.cwiseAbs().maxCoeff() > isowrench::kMaxMeasuredWrench) {
        __builtin_trap();
      }
    }
  } catch (const isowrench::Error&) {
  }
  return 0;
}
