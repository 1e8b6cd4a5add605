// Uncertainty studies (issue 30; docs/performance.md "Uncertainty studies"): the stiffness-only
// Monte Carlo against EvaluateBatch on the same stiffness sets, and angle and muscle point
// perturbations on the 5-dof rat, in evaluations and samples per second.

#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include "isowrench/engine.hpp"
#include "isowrench/uncertainty.hpp"

namespace {

const isowrench::Model& Rat5() {
  static const isowrench::Model model = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_BENCH_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  return model;
}

constexpr long kSamples = 16384;
const char* const kDofs[6] = {"x", "y", "z", "rx", "ry", "rz"};

isowrench::UncertaintySpec StiffnessSpec() {
  isowrench::UncertaintySpec spec;
  for (const char* dof : kDofs) {
    isowrench::UncertainInput in;
    in.name = std::string("transducer_stiffness:") + dof;
    in.distribution = isowrench::InputDistribution::kLogNormal;
    in.sd = {0.5};
    spec.inputs.push_back(in);
  }
  return spec;
}

// The engine alone on the evaluations of the stiffness-only study: one posture x N (6 + 2)
// stiffness sets drawn log-normal, on state.range(0) threads.
void BM_UncertaintyEngineReference(benchmark::State& state) {
  const isowrench::Model& model = Rat5();
  const long evaluations = kSamples * 8;
  std::vector<isowrench::StiffnessSet> sets(static_cast<size_t>(evaluations),
                                            model.model_stiffness());
  for (long s = 0; s < evaluations; ++s) {
    for (int r = 0; r < 6; ++r) {
      const auto u = isowrench::PhiloxUniforms(1, static_cast<std::uint64_t>(s), 0, 0);
      sets[static_cast<size_t>(s)].s_t[r] *=
          std::exp(0.5 * isowrench::NormalQuantile(u[static_cast<size_t>(r % 4)]));
    }
  }
  std::vector<isowrench::WrenchResult> out;
  isowrench::BatchOptions options;
  options.threads = static_cast<int>(state.range(0));
  const Eigen::MatrixXd posture = model.nominal_posture();
  for (auto _ : state) {
    isowrench::EvaluateBatch(model, posture, 0, sets, out, 1.0, options);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * evaluations);
}
BENCHMARK(BM_UncertaintyEngineReference)
    ->Arg(1)
    ->Arg(2)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The stiffness-only study: six log-normal S_t entries, Sobol design (N x 8 evaluations).
void BM_UncertaintyStiffnessOnly(benchmark::State& state) {
  const isowrench::Model& model = Rat5();
  isowrench::UncertaintyOptions options;
  options.samples = kSamples;
  options.threads = static_cast<int>(state.range(0));
  const isowrench::UncertaintySpec spec = StiffnessSpec();
  long evaluations = 0;
  for (auto _ : state) {
    const isowrench::UncertaintyResult r =
        isowrench::RunUncertainty(model, "GP", model.nominal_posture(), spec, options);
    evaluations = r.evaluations;
    benchmark::DoNotOptimize(r.postures.data());
  }
  state.SetItemsProcessed(state.iterations() * evaluations);
  state.counters["samples_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * kSamples), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_UncertaintyStiffnessOnly)
    ->Arg(1)
    ->Arg(2)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Angle perturbations of every coordinate of the 5-dof rat (normal, 2 deg) and the force:
// every evaluation has its own kinematics. Samples per second is the measure.
void BM_UncertaintyAngles(benchmark::State& state) {
  const isowrench::Model& model = Rat5();
  isowrench::UncertaintySpec spec;
  for (const std::string& c : model.joint_names()) {
    isowrench::UncertainInput in;
    in.name = "angle:" + c;
    in.sd = {2.0};
    spec.inputs.push_back(in);
  }
  isowrench::UncertainInput force;
  force.name = "max_force";
  force.sd = {0.2};
  spec.inputs.push_back(force);
  isowrench::UncertaintyOptions options;
  options.samples = kSamples;
  options.threads = static_cast<int>(state.range(0));
  options.sobol = state.range(1) != 0;
  long evaluations = 0;
  for (auto _ : state) {
    const isowrench::UncertaintyResult r =
        isowrench::RunUncertainty(model, "GP", model.nominal_posture(), spec, options);
    evaluations = r.evaluations;
    benchmark::DoNotOptimize(r.postures.data());
  }
  state.SetItemsProcessed(state.iterations() * evaluations);
  state.counters["samples_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * kSamples), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_UncertaintyAngles)
    ->Args({2, 0})
    ->Args({2, 1})
    ->Args({1, 1})
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Muscle path points of the 5-dof rat's GP (origin and insertion, normal, 1 mm on each axis):
// every evaluation moves the points through SetPathPointOffsets (the moving-point kernel, no
// Model rebuilt). state.range(1): with the five angles (2 deg) too. Samples per second is the
// issue's measure.
void BM_UncertaintyPoints(benchmark::State& state) {
  const isowrench::Model& model = Rat5();
  isowrench::UncertaintySpec spec;
  for (const char* point : {"point:GP:0", "point:GP:1"}) {
    isowrench::UncertainInput in;
    in.name = point;
    in.sd = {1.0};
    spec.inputs.push_back(in);
  }
  if (state.range(1) != 0) {
    for (const std::string& c : model.joint_names()) {
      isowrench::UncertainInput in;
      in.name = "angle:" + c;
      in.sd = {2.0};
      spec.inputs.push_back(in);
    }
  }
  isowrench::UncertaintyOptions options;
  options.samples = kSamples;
  options.threads = static_cast<int>(state.range(0));
  options.sobol = state.range(2) != 0;
  long evaluations = 0;
  for (auto _ : state) {
    const isowrench::UncertaintyResult r =
        isowrench::RunUncertainty(model, "GP", model.nominal_posture(), spec, options);
    evaluations = r.evaluations;
    benchmark::DoNotOptimize(r.postures.data());
  }
  state.SetItemsProcessed(state.iterations() * evaluations);
  state.counters["samples_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * kSamples), benchmark::Counter::kIsRate);
}
// Arguments: threads, angles too, Sobol indices.
BENCHMARK(BM_UncertaintyPoints)
    ->Args({2, 0, 0})
    ->Args({2, 0, 1})
    ->Args({1, 0, 1})
    ->Args({2, 1, 1})
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
