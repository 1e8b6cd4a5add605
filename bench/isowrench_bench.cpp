// Google Benchmark: kernel K (GP on rat_hindlimb_5dof_base.urdf) through the library's fast
// path against the straightforward KDL baseline in kdl_baseline.cpp, in one run, plus the batch
// APIs and the 181 x 181 posture x 20 stiffness-ratio sweep. After the runs a summary prints
// ns per evaluation and the ratio to the KDL baseline. Instruction counts come from callgrind
// (`cmake --build <dir> --target bench_instructions`): this machine has no hardware counters.

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "bench_common.hpp"
#include "kdl_baseline.hpp"

using namespace isowrench_bench;

namespace {

struct Fixture {
  isowrench::Model model = isowrench::Model::FromUrdfFile(KernelUrdf());
  isowrench::Model compiled{model};
  Eigen::MatrixXd postures = KernelPostures(model, 1 << 16);
  std::vector<isowrench::StiffnessSet> sets = KernelStiffnessSets(compiled);
  isowrench::Model coupled = CoupledKernelModel();  // kernel K with the spline-coupled knee
};

Fixture& F() {
  static Fixture fixture;
  return fixture;
}

void BM_KdlBaseline(benchmark::State& state) {
  Fixture& f = F();
  KdlBaseline kdl(f.model, 0);
  const isowrench::StiffnessSet& st = f.sets[0];
  const Eigen::VectorXd s_p = st.s_p;
  long i = 0;
  for (auto _ : state) {
    const Eigen::VectorXd q = f.postures.col(i++ & 1023);
    benchmark::DoNotOptimize(kdl.Evaluate(q, st.s_t, s_p));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KdlBaseline);

void BM_ReferenceEvaluateWrench(benchmark::State& state) {
  Fixture& f = F();
  long i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(isowrench::EvaluateWrench(f.model, f.postures.col(i++ & 1023), "GP"));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ReferenceEvaluateWrench);

// One posture at a time, on kernel K or (coupled) kernel K with the spline-coupled knee.
void FastSingle(benchmark::State& state, const isowrench::Model& model) {
  Fixture& f = F();
  isowrench::Data ws(model);
  long i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        isowrench::Evaluate(model, ws, f.postures.col(i++ & 1023), 0, f.sets[0]));
  }
  state.SetItemsProcessed(state.iterations());
}
void BM_FastSingle(benchmark::State& state) { FastSingle(state, F().compiled); }
BENCHMARK(BM_FastSingle);
void BM_FastSingleCoupledKnee(benchmark::State& state) { FastSingle(state, F().coupled); }
BENCHMARK(BM_FastSingleCoupledKnee);

// Many postures, one stiffness set, `threads` worker threads.
void FastBatchPostures(benchmark::State& state, const isowrench::Model& model) {
  Fixture& f = F();
  std::vector<isowrench::StiffnessSet> one = {f.sets[0]};
  std::vector<isowrench::WrenchResult> out;
  isowrench::BatchOptions options;
  options.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    isowrench::EvaluateBatch(model, f.postures, 0, one, out, 1.0, options);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * f.postures.cols());
  state.counters["threads"] = options.threads;
}
void BM_FastBatchPostures(benchmark::State& state) { FastBatchPostures(state, F().compiled); }
BENCHMARK(BM_FastBatchPostures)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
void BM_FastBatchPosturesCoupledKnee(benchmark::State& state) {
  FastBatchPostures(state, F().coupled);
}
BENCHMARK(BM_FastBatchPosturesCoupledKnee)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Postures x 20 stiffness sets: kinematics once per posture, 20 solves.
void BM_FastBatchStiffness(benchmark::State& state) {
  Fixture& f = F();
  const Eigen::MatrixXd postures = f.postures.leftCols(4096);
  std::vector<isowrench::WrenchResult> out;
  isowrench::BatchOptions options;
  options.threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    isowrench::EvaluateBatch(f.compiled, postures, 0, f.sets, out, 1.0, options);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * postures.cols() * static_cast<long>(f.sets.size()));
  state.counters["threads"] = options.threads;
}
BENCHMARK(BM_FastBatchStiffness)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// The sweep: hip_rz x knee_rz on a 181 x 181 grid (1 degree steps) x 20 ratios, both
// cores, including building the posture grid.
void BM_Sweep181x181x20(benchmark::State& state) {
  Fixture& f = F();
  const int hip = f.model.JointIndex("hip_rz"), knee = f.model.JointIndex("knee_rz");
  const Eigen::VectorXd nominal = f.model.nominal_posture();
  std::vector<isowrench::WrenchResult> out;
  isowrench::BatchOptions options;
  options.threads = 2;
  for (auto _ : state) {
    Eigen::MatrixXd grid(f.model.dof_count(), 181 * 181);
    for (int a = 0; a < 181; ++a) {
      for (int b = 0; b < 181; ++b) {
        auto col = grid.col(a * 181 + b);
        col = nominal;
        col[hip] = (-200.0 + a) * M_PI / 180.0;
        col[knee] = (15.0 + b) * M_PI / 180.0;
      }
    }
    isowrench::EvaluateBatch(f.compiled, grid, 0, f.sets, out, 1.0, options);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * 181L * 181L * static_cast<long>(f.sets.size()));
  state.counters["threads"] = options.threads;
}
BENCHMARK(BM_Sweep181x181x20)->UseRealTime()->Unit(benchmark::kMillisecond);

/// CPU seconds of the whole process (all threads), for benchmarks whose work runs on threads
/// the benchmark library does not time.
double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// The fitting target: 1,000 simulated trials (rat_hindlimb_5dof.urdf, a base compliance
// of 1e7 N/m as the truth, the default noise) fitted against the whole candidate-effect library:
// the full loop of isowrench::FitEffects (screening, fits on FitOptions::threads = all cores,
// cross-validation, decisions, report). One item = one whole fit. Counters: candidates in the
// library, candidates fully fitted over all rounds, process CPU seconds per fit (all threads).
void BM_Fit1000TrialsWholeLibrary(benchmark::State& state) {
  const isowrench::Model nominal = isowrench::Model::FromUrdfFile(
      std::string(ISOWRENCH_BENCH_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  isowrench::SimulationOptions simulation;
  simulation.postures = 1000;
  simulation.seed = 3;
  const std::vector<isowrench::Trial> trials = isowrench::SimulateTrials(
      nominal,
      isowrench::ApplyEffects(nominal.description(),
                              {isowrench::ParseEffectAssignment(nominal, "base_isotropic=1e7")}),
      simulation);
  std::size_t candidates = 0, fitted = 0;
  const double cpu_start = ProcessCpuSeconds();
  for (auto _ : state) {
    const isowrench::FitReport report = isowrench::FitEffects(nominal, trials);
    candidates = report.rounds.empty() ? 0 : report.rounds.front().candidates.size();
    fitted = 0;
    for (const isowrench::FitRound& round : report.rounds) {
      for (const isowrench::CandidateFit& f : round.candidates) fitted += !f.screened_out;
    }
    benchmark::DoNotOptimize(report.rounds.size());
  }
  state.counters["candidates"] = static_cast<double>(candidates);
  state.counters["fitted"] = static_cast<double>(fitted);
  state.counters["cpu_s_per_fit"] =
      (ProcessCpuSeconds() - cpu_start) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_Fit1000TrialsWholeLibrary)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(5);

// Console output as usual, plus a record of every run for the summary.
class RecordingReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      if (run.run_type != Run::RT_Iteration) continue;
      auto it = run.counters.find("items_per_second");
      if (it == run.counters.end()) continue;
      const double threads = run.counters.count("threads") ? run.counters.at("threads").value : 1.0;
      records_.push_back(
          {run.benchmark_name(), 1e9 / it->second.value, threads, run.GetAdjustedRealTime()});
    }
  }
  struct Record {
    std::string name;
    double ns_per_evaluation;  // wall-clock ns per evaluation (all threads together)
    double threads;
    double real_time;  // in the benchmark's unit
  };
  const std::vector<Record>& records() const { return records_; }

 private:
  std::vector<Record> records_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RecordingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  double kdl = 0.0;
  for (const auto& r : reporter.records()) {
    if (r.name.rfind("BM_KdlBaseline", 0) == 0) kdl = r.ns_per_evaluation;
  }
  std::printf("\nSummary (kernel K: GP on rat_hindlimb_5dof_base.urdf, m = 8)\n");
  std::printf("%-44s %14s %16s %12s\n", "benchmark", "ns/eval (wall)", "ns/eval/core",
              "KDL / this");
  for (const auto& r : reporter.records()) {
    const double per_core = r.ns_per_evaluation * r.threads;
    char ratio[32] = "-";
    if (kdl > 0) std::snprintf(ratio, sizeof(ratio), "%.1fx", kdl / r.ns_per_evaluation);
    std::printf("%-44s %14.1f %16.1f %12s\n", r.name.c_str(), r.ns_per_evaluation, per_core, ratio);
  }
  benchmark::Shutdown();
  return 0;
}
