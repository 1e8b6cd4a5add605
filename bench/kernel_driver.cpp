// Runs one kernel N times inside isowrench_measured_loop, for instruction counts under
// callgrind (this machine exposes no hardware counters):
//   valgrind --tool=callgrind --toggle-collect=isowrench_measured_loop
//     ./isowrench_kernel_driver fast 10000   (one command line)
// instructions per evaluation = Ir collected / evaluations (printed by the driver).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "bench_common.hpp"
#include "kdl_baseline.hpp"

using namespace isowrench_bench;

namespace {

struct Setup {
  isowrench::Model model = isowrench::Model::FromUrdfFile(KernelUrdf());
  isowrench::Model compiled{model};
  isowrench::Data ws{compiled};
  Eigen::MatrixXd postures = KernelPostures(model, 1024);
  std::vector<isowrench::StiffnessSet> sets = KernelStiffnessSets(compiled);
  KdlBaseline kdl{model, 0};
  std::vector<isowrench::WrenchResult> out;
  isowrench::Model coupled{CoupledKernelModel()};
  isowrench::Data coupled_ws{coupled};
  isowrench::Model wrapped{WrappedKernelModel(isowrench::WrapMode::kOpenSim)};
  isowrench::Data wrapped_ws{wrapped};
  isowrench::Model wrapped_exact{WrappedKernelModel(isowrench::WrapMode::kExact)};
  isowrench::Data wrapped_exact_ws{wrapped_exact};
  isowrench::Model rigid{ForceKernelModel(true)};
  isowrench::Model compliant{ForceKernelModel(false)};
};

// A synthetic chain (ChainModel) named by a kernel "fast-chain-N" or "batch-chain-N" (N
// coordinates, one joint each) or "...-Nc" (each driving a second, spline-coupled joint).
struct Chain {
  explicit Chain(const char* spec)
      : model(ChainModel(std::atoi(spec), spec[std::strlen(spec) - 1] == 'c')),
        ws(model),
        postures(KernelPostures(model, 1024)) {}
  isowrench::Model model;
  isowrench::Data ws;
  Eigen::MatrixXd postures;
  std::vector<isowrench::WrenchResult> out;
};

double g_sink = 0.0;

// n passes of EvaluateBatch (one thread) over `postures` with `sets`; returns the evaluations.
long BatchPasses(const isowrench::Model& model, const Eigen::MatrixXd& postures,
                 const std::vector<isowrench::StiffnessSet>& sets,
                 std::vector<isowrench::WrenchResult>& out, long n) {
  isowrench::BatchOptions options;
  options.threads = 1;
  for (long i = 0; i < n; ++i) {
    isowrench::EvaluateBatch(model, postures, 0, sets, out, 1.0, options);
    g_sink += out[0].wrench[0];
  }
  return n * postures.cols() * static_cast<long>(sets.size());
}

}  // namespace

// Returns the number of evaluations done.
extern "C" __attribute__((noinline)) long isowrench_measured_loop(Setup& s, Chain* chain,
                                                                  const char* kernel, long n) {
  const isowrench::StiffnessSet& st = s.sets[0];
  if (chain != nullptr && kernel[0] == 'f') {  // fast-chain-N: one posture at a time
    const isowrench::StiffnessSet set = chain->model.model_stiffness();
    for (long i = 0; i < n; ++i) {
      g_sink += isowrench::Evaluate(chain->model, chain->ws, chain->postures.col(i & 1023), 0, set)
                    .wrench[0];
    }
    return n;
  }
  if (chain != nullptr) {  // batch-chain-N: 1024 postures per call, one thread
    return BatchPasses(chain->model, chain->postures, {chain->model.model_stiffness()}, chain->out,
                       n);
  }
  if (std::strcmp(kernel, "fast") == 0) {
    for (long i = 0; i < n; ++i) {
      g_sink += isowrench::Evaluate(s.compiled, s.ws, s.postures.col(i & 1023), 0, st).wrench[0];
    }
    return n;
  }
  if (std::strcmp(kernel, "fast-coupled") == 0) {  // kernel K with the spline-coupled knee
    for (long i = 0; i < n; ++i) {
      g_sink +=
          isowrench::Evaluate(s.coupled, s.coupled_ws, s.postures.col(i & 1023), 0, st).wrench[0];
    }
    return n;
  }
  // Kernel K with GP over one cylinder at the knee (WrappedKernelModel), OpenSim's and the
  // exact mode: against "fast", the same muscle without the wrap.
  if (std::strcmp(kernel, "fast-wrap") == 0 || std::strcmp(kernel, "fast-wrap-exact") == 0) {
    const bool exact = kernel[9] == '-';
    const isowrench::Model& model = exact ? s.wrapped_exact : s.wrapped;
    isowrench::Data& ws = exact ? s.wrapped_exact_ws : s.wrapped_ws;
    for (long i = 0; i < n; ++i) {
      g_sink += isowrench::Evaluate(model, ws, s.postures.col(i & 1023), 0, st).wrench[0];
    }
    return n;
  }
  // The same in the batch (EvaluateBatch, one thread): a wrapping muscle's kinematics posture by
  // posture on the scalar path, its statics in the lanes.
  if (std::strcmp(kernel, "batch-wrap") == 0) {
    return BatchPasses(s.wrapped, s.postures, {st}, s.out, n);
  }
  if (std::strcmp(kernel, "batch-coupled") == 0) {
    return BatchPasses(s.coupled, s.postures, {st}, s.out, n);
  }
  // Kernel K with GP's force model (ForceKernelModel): the force stage after the path stage.
  if (std::strcmp(kernel, "fast-rigid") == 0 || std::strcmp(kernel, "fast-compliant") == 0) {
    const isowrench::Model& m = kernel[5] == 'r' ? s.rigid : s.compliant;
    isowrench::Data ws(m);
    for (long i = 0; i < n; ++i) {
      g_sink += isowrench::Evaluate(m, ws, s.postures.col(i & 1023), 0, st).wrench[0];
    }
    return n;
  }
  if (std::strcmp(kernel, "batch-rigid") == 0 || std::strcmp(kernel, "batch-compliant") == 0) {
    const isowrench::Model& m = kernel[6] == 'r' ? s.rigid : s.compliant;
    return BatchPasses(m, s.postures, {st}, s.out, n);
  }
  if (std::strcmp(kernel, "fast-stiffness") == 0) {  // kinematics once, 20 stiffness sets
    for (long i = 0; i < n; ++i) {
      isowrench::ComputeKinematics(s.compiled, s.ws, s.postures.col(i & 1023), 0);
      for (const auto& set : s.sets)
        g_sink += isowrench::SolveStatics(s.compiled, s.ws, set).wrench[0];
    }
    return n * static_cast<long>(s.sets.size());
  }
  if (std::strcmp(kernel, "batch") == 0 || std::strcmp(kernel, "batch-stiffness") == 0) {
    // The lane kernel on one thread: n passes over the 1024 postures, with one or 20 sets.
    if (kernel[5] == '-') return BatchPasses(s.compiled, s.postures, s.sets, s.out, n);
    return BatchPasses(s.compiled, s.postures, {st}, s.out, n);
  }
  if (std::strcmp(kernel, "kdl") == 0) {
    const Eigen::VectorXd s_p = st.s_p;
    for (long i = 0; i < n; ++i) {
      const Eigen::VectorXd q = s.postures.col(i & 1023);
      g_sink += s.kdl.Evaluate(q, st.s_t, s_p)[0];
    }
    return n;
  }
  if (std::strcmp(kernel, "reference") == 0) {
    for (long i = 0; i < n; ++i) {
      g_sink +=
          isowrench::EvaluateWrench(s.model, s.postures.col(i & 1023), "GP").statics.wrench[0];
    }
    return n;
  }
  std::fprintf(
      stderr,
      "unknown kernel '%s' (fast, fast-stiffness, fast-coupled, fast-wrap, fast-wrap-exact, "
      "fast-rigid, fast-compliant, batch, batch-stiffness, batch-coupled, batch-wrap, batch-rigid, "
      "batch-compliant, kdl, reference, fast-chain-N[c], batch-chain-N[c])\n",
      kernel);
  std::exit(2);
}

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr,
                 "usage: %s "
                 "fast|fast-stiffness|fast-coupled|fast-wrap|fast-wrap-exact|fast-rigid|"
                 "fast-compliant|batch|batch-stiffness|batch-coupled|batch-wrap|batch-rigid|"
                 "batch-compliant|"
                 "kdl|"
                 "reference|fast-chain-N[c]|batch-chain-N[c] <count>\n",
                 argv[0]);
    return 2;
  }
  Setup s;
  const long n = std::atol(argv[2]);
  const char* chain_spec = std::strstr(argv[1], "-chain-");
  std::unique_ptr<Chain> chain;
  if (chain_spec != nullptr) chain = std::make_unique<Chain>(chain_spec + 7);
  // Warm-up and measurement both run inside the collected function: report their sum.
  const long evaluations = isowrench_measured_loop(s, chain.get(), argv[1], std::min(16L, n)) +
                           isowrench_measured_loop(s, chain.get(), argv[1], n);
  std::printf("%s: %ld evaluations collected (checksum %.6g)\n", argv[1], evaluations, g_sink);
  if (std::strncmp(argv[1], "fast-wrap", 9) == 0) {  // how often the cylinder engages
    int wrapped = 0;
    for (int p = 0; p < 1024; ++p) {
      const Eigen::VectorXd q = s.postures.col(p);
      wrapped += isowrench::MuscleWrappedPath(s.wrapped, s.wrapped_ws, q, 0).wraps[0].wrapped;
    }
    std::printf("the cylinder wraps GP at %d of the 1024 postures\n", wrapped);
  }
  if (std::strstr(argv[1], "-rigid") || std::strstr(argv[1], "-compliant")) {
    // Outside the measured loop: how the force stage ends over the 1024 postures.
    const isowrench::Model& m = std::strstr(argv[1], "-rigid") ? s.rigid : s.compliant;
    isowrench::Data ws(m);
    int counts[4] = {0, 0, 0, 0};
    for (int p = 0; p < 1024; ++p) {
      isowrench::ComputeKinematics(m, ws, s.postures.col(p), 0);
      ++counts[static_cast<int>(isowrench::MuscleForceAt(m, 0, ws.muscle_length(), 1.0).status)];
    }
    std::printf(
        "force stage over the 1024 postures: %d equilibrium, %d slack, %d fiber at minimum "
        "length, %d no equilibrium\n",
        counts[0], counts[1], counts[2], counts[3]);
  }
  return 0;
}
