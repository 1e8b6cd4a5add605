// Batch evaluation: postures split in chunks over worker threads, one workspace per thread,
// kinematics once per posture and one statics solve per stiffness set.

#include <algorithm>
#include <atomic>
#include <thread>

#include "fast/fast_impl.hpp"
#include "isowrench/error.hpp"

namespace isowrench {
namespace {

// Postures handed to a worker at a time: large enough that the shared counter is touched rarely,
// small enough that both threads finish together and progress moves smoothly.
constexpr long kChunk = 256;

}  // namespace

void EvaluateBatch(const CompiledModel& model, const Eigen::Ref<const Eigen::MatrixXd>& postures,
                   int muscle, const std::vector<StiffnessSet>& stiffness,
                   std::vector<FastWrench>& out, double activation, const BatchOptions& options) {
  const int m = model.dof_count();
  if (postures.rows() != m) {
    throw Error("EvaluateBatch: postures have " + std::to_string(postures.rows()) + " rows; model '" +
                model.model().name() + "' has " + std::to_string(m) + " joints");
  }
  if (!postures.allFinite()) throw Error("EvaluateBatch: a posture has a non-finite entry");
  if (muscle < 0 || muscle >= model.muscle_count()) {
    throw Error("EvaluateBatch: muscle index " + std::to_string(muscle) + " is out of range (model '" +
                model.model().name() + "' has " + std::to_string(model.muscle_count()) + " muscles)");
  }
  if (stiffness.empty()) throw Error("EvaluateBatch: no stiffness set given");
  for (size_t s = 0; s < stiffness.size(); ++s) {
    if (stiffness[s].s_p.size() != m) {
      throw Error("EvaluateBatch: stiffness set " + std::to_string(s) + " has " +
                  std::to_string(stiffness[s].s_p.size()) + " S_p entries for " + std::to_string(m) +
                  " joints");
    }
  }
  if (!std::isfinite(activation)) throw Error("EvaluateBatch: activation is not finite");
  const long P = static_cast<long>(postures.cols());
  const long S = static_cast<long>(stiffness.size());
  out.assign(static_cast<size_t>(P * S), FastWrench{});
  if (P == 0) {
    if (options.progress) options.progress(0, 0);
    return;
  }
  const long chunks = (P + kChunk - 1) / kChunk;
  const int threads = static_cast<int>(std::clamp<long>(options.threads, 1, chunks));
  std::atomic<long> next_chunk{0};
  std::atomic<long> done{0};
  FastWrench* results = out.data();

  auto work = [&](bool report) {
    FastWorkspace ws(model);
    for (;;) {
      const long chunk = next_chunk.fetch_add(1, std::memory_order_relaxed);
      if (chunk >= chunks) break;
      const long begin = chunk * kChunk;
      const long end = std::min(P, begin + kChunk);
      for (long p = begin; p < end; ++p) {
        FastWrench* row = results + p * S;
        if (!ComputeFastKinematics(model, ws, postures.col(p), muscle, activation)) {
          for (long s = 0; s < S; ++s) row[s] = FastWrench{};
          continue;
        }
        for (long s = 0; s < S; ++s) row[s] = SolveFastStatics(model, ws, stiffness[s], options.solve);
      }
      const long total_done = done.fetch_add(end - begin, std::memory_order_relaxed) + (end - begin);
      if (report && options.progress) options.progress(total_done, P);
    }
  };
  std::vector<std::thread> helpers;
  helpers.reserve(static_cast<size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) helpers.emplace_back(work, false);
  work(true);
  for (std::thread& t : helpers) t.join();
  if (options.progress) options.progress(P, P);
}

}  // namespace isowrench
