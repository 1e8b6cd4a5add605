// libFuzzer harness: trial CSV text -> TrialReader (RFC 4180 records, header checks, units,
// dialects, range checks) against the 5-dof rat hindlimb. isowrench::Error is the expected
// answer to bad input.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/trial_csv.hpp"

namespace {
const isowrench::Model* g_model = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  isowrench::SetWarningHandler([](const std::string&) {});
  g_model = new isowrench::Model(isowrench::Model::FromUrdfFile(ISOWRENCH_FUZZ_URDF));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The first byte, when it is not text, chooses the sheet's dialect (delimiter, decimal comma,
  // skipped rows, posture sheet); the rest is the sheet. Plain text inputs read as ',' CSV.
  isowrench::TrialSheetOptions sheet;
  if (size > 0 && data[0] >= 0xF0) {
    const unsigned bits = data[0] & 0x0F;
    const char delimiters[4] = {',', ';', '\t', '|'};
    sheet.delimiter = delimiters[bits & 3];
    sheet.decimal_comma = (bits & 4) && sheet.delimiter != ',';
    sheet.postures_only = (bits & 8) != 0;
    sheet.skip_rows = static_cast<int>(bits & 1);
    sheet.ignore_columns = {"trial", "comment"};
    ++data;
    --size;
  }
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    isowrench::TrialReader reader(*g_model, in, "fuzz.csv", sheet);
    isowrench::Trial t;
    while (reader.Next(&t)) {
      // Whatever the reader accepts is a finite, plausible measurement.
      const bool activation_ok = (t.activation >= 0 && t.activation <= 1) ||
                                 (sheet.postures_only && std::isnan(t.activation));
      if (!t.q.allFinite() || !t.wrench.allFinite() || !activation_ok ||
          t.wrench.cwiseAbs().maxCoeff() > isowrench::kMaxMeasuredWrench) {
        __builtin_trap();
      }
    }
  } catch (const isowrench::Error&) {
  }
  return 0;
}
