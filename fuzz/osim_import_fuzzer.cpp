// libFuzzer harness: OpenSim .osim text -> ImportOpenSimString -> Model -> EvaluateWrench of
// every imported muscle at the nominal posture; the imported description must also survive
// WriteUrdfString -> ReadUrdfString (what `isowrench import` writes, every other command reads).
// The clamp and endpoint bodies are taken from the document itself: "ground" and its first
// <Body>, each to its first four <Body> elements. isowrench::Error is the expected answer to bad
// input; any other exception, a crash, a sanitizer report, a hang, a non-finite "ok" wrench or
// an import whose URDF the reader refuses is a finding.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/model.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/statics.hpp"

namespace {

// Names of the <Body name="..."> elements, in document order (at most 16).
std::vector<std::string> BodyNames(const std::string& xml) {
  std::vector<std::string> names;
  const std::string tag = "<Body name=\"";
  for (size_t at = xml.find(tag); at != std::string::npos && names.size() < 16;
       at = xml.find(tag, at + 1)) {
    const size_t begin = at + tag.size();
    const size_t end = xml.find('"', begin);
    if (end == std::string::npos || end - begin > 64) break;
    names.push_back(xml.substr(begin, end - begin));
  }
  return names;
}

void ImportAndEvaluate(const std::string& xml, const std::string& clamp,
                       const std::string& endpoint) {
  isowrench::OpenSimImportOptions options;
  options.clamp_body = clamp;
  options.endpoint_body = endpoint;
  isowrench::OpenSimImport import;
  try {
    import = isowrench::ImportOpenSimString(xml, "fuzz.osim", options);
  } catch (const isowrench::Error&) {
    return;  // bad input, refused with a message
  }
  std::string urdf;
  try {
    urdf = isowrench::WriteUrdfString(import.description);
  } catch (const isowrench::Error&) {
    return;  // e.g. the import produced a limb without a movable joint
  }
  try {
    isowrench::ReadUrdfString(urdf, "fuzz-import.urdf");
  } catch (const isowrench::Error&) {
    __builtin_trap();  // an accepted import must be readable back
  }
  try {
    isowrench::Model model(import.description);
    const Eigen::VectorXd q = model.nominal_posture();
    for (int i = 0; i < model.muscle_count(); ++i) {
      const isowrench::WrenchEvaluation e =
          isowrench::EvaluateWrench(model, q, model.muscle(i).name, 0.5);
      if (e.statics.ok() && !e.statics.wrench.allFinite()) __builtin_trap();
    }
  } catch (const isowrench::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  isowrench::SetWarningHandler([](const std::string&) {});  // warnings are legal output
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return -1;  // .osim limbs for this tool are small
  const std::string xml(reinterpret_cast<const char*>(data), size);
  const std::vector<std::string> bodies = BodyNames(xml);
  if (bodies.empty()) {
    ImportAndEvaluate(xml, "ground", "ground");  // still exercises the reader's errors
    return 0;
  }
  // From ground and from the first body to each of the first four bodies (the limb's chain is
  // usually listed first; later bodies are often off the chain, which the importer refuses).
  for (const std::string& clamp : {std::string("ground"), bodies.front()}) {
    if (clamp == "ground" && bodies.front() == "ground") continue;  // 3.x lists ground as a body
    for (size_t k = 0; k < bodies.size() && k < 4; ++k) {
      if (bodies[k] != clamp) ImportAndEvaluate(xml, clamp, bodies[k]);
    }
  }
  return 0;
}
