// Batch evaluation: units of postures x stiffness sets over worker threads; in each, four
// evaluations at a time in the lane kernel (four postures, or one posture and four sets), the
// lanes it leaves undecided redone on the scalar path.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <thread>

#include "fast/fast_impl.hpp"
#include "fast/lanes.hpp"
#include "fast/simd.hpp"
#include "isowrench/error.hpp"

namespace isowrench {

namespace sincos {
// Defined here, away from the kernels that use it (simd.hpp: kLaneConstants).
alignas(32) const V4 kLaneConstants[kConstantCount] = {
    kKnownLaneConstants[kS1],      kKnownLaneConstants[kS2],      kKnownLaneConstants[kS3],
    kKnownLaneConstants[kS4],      kKnownLaneConstants[kS5],      kKnownLaneConstants[kS6],
    kKnownLaneConstants[kC1],      kKnownLaneConstants[kC2],      kKnownLaneConstants[kC3],
    kKnownLaneConstants[kC4],      kKnownLaneConstants[kC5],      kKnownLaneConstants[kC6],
    kKnownLaneConstants[kReduce1], kKnownLaneConstants[kReduce2], kKnownLaneConstants[kReduce3],
    kKnownLaneConstants[kHalf],    kKnownLaneConstants[kOne]};
}  // namespace sincos

namespace {

// Work is cut into units of (a block of postures) x (a block of stiffness sets), handed out
// through a shared counter. Posture blocks hold at most kMaxPostureBlock postures (a multiple
// of the lane count) and are made small enough that each thread gets several units; when there
// are too few postures for that, the stiffness sets are split too, so one posture with many
// stiffness sets still uses every thread.
constexpr long kMaxPostureBlock = 256;
constexpr long kUnitsPerThread = 8;
// Groups of four postures whose force stage a compliant tendon computes at once (BlockLanes;
// their J and tau take 7 KB per group on a small chain, 896 KB per thread): a whole posture
// block, of up to kMaxBlockPostures. Its lengths are sorted into lane groups, and more lengths
// sort into closer neighbours: a compliant tendon's batch takes a quarter as many, up to four
// times as large, units (docs/performance.md).
constexpr long kMaxBlockPostures = 512;
constexpr long kBlockGroups = kMaxBlockPostures / kLanes;
constexpr long kBlockUnitsPerThread = 2;

// Whether a muscle's batch force stage runs over whole blocks (BlockLanes): a compliant
// tendon's, on a muscle whose kinematics run in the lanes.
bool BlockForceStage(const FastMuscle& mu) {
  return !mu.dynamic && mu.force_curve && !mu.force_model.rigid_tendon() &&
         mu.force_model.type() != ForceModelType::kConstant;
}

long RoundUpToLanes(long n) { return (n + kLanes - 1) / kLanes * kLanes; }

// Whether q[0 .. count) holds an inf or NaN: the sum of 0 * q_i is 0 exactly when every entry
// is finite (NaN otherwise), four entries per vector multiply-add (AVX2 where the CPU has it).
ISOWRENCH_CLONES bool AnyNonFinite(const double* q, long count) {
  V4 sum = ISOWRENCH_V4_SPLAT(0.0);
  long i = 0;
  for (; i + 4 <= count; i += 4) {
    V4 x;
    std::memcpy(&x, q + i, sizeof x);
    sum += 0.0 * x;
  }
  double tail = 0.0;
  for (; i < count; ++i) tail += 0.0 * q[i];
  return ((sum[0] + sum[1]) + (sum[2] + sum[3])) + tail != 0.0;
}

// A set the solve accepts: finite, non-negative compliances (the scalar path's input check;
// the torque is finite because postures and activation are).
bool ValidStiffness(const StiffnessSet& s) {
  return s.s_t.allFinite() && s.s_p.allFinite() && (s.s_t.array() >= 0.0).all() &&
         (s.s_p.array() >= 0.0).all();
}

// One thread's evaluator: the lane workspace, plus one scalar workspace per lane for the
// evaluations the lanes leave undecided (and for postures evaluated alone), each built the
// first time it is needed.
class UnitEvaluator {
 public:
  UnitEvaluator(const Model& model, const Eigen::Ref<const Eigen::MatrixXd>& postures, int muscle,
                const std::vector<StiffnessSet>& stiffness, const std::vector<char>& valid,
                double activation, const SolveOptions& options, WrenchResult* results)
      : model_(model),
        postures_(postures),
        muscle_(muscle),
        stiffness_(stiffness),
        valid_(valid),
        activation_(activation),
        options_(options),
        results_(results),
        lanes_(model) {}

  // Postures [p0, p1) x sets [s0, s1).
  void Run(long p0, long p1, long s0, long s1) {
    long p = p0;
    // A muscle with moving or conditional points has its kinematics on the scalar path,
    // posture by posture (SetLanes); the statics still runs four stiffness sets at a time.
    const FastMuscle& mu = model_.impl().flat.muscles[muscle_];
    const bool scalar_kinematics = mu.dynamic;
    // A compliant tendon's force stage over up to kBlockGroups groups at once (BlockLanes).
    if (BlockForceStage(mu) && LaneGroupSize(lanes_) > 0) {
      while (p1 - p >= 2 * kLanes) {
        const long groups = std::min<long>(kBlockGroups, (p1 - p) / kLanes);
        BlockLanes(mu, p, groups, s0, s1);
        p += groups * kLanes;
      }
    }
    // Groups of kLanes postures in the lanes; a short tail too when there are too few sets to
    // fill the lanes instead.
    while (!scalar_kinematics && p < p1 && (p1 - p >= kLanes || s1 - s0 < kLanes)) {
      const int lanes = static_cast<int>(std::min<long>(kLanes, p1 - p));
      PostureLanes(p, lanes, s0, s1);
      p += lanes;
    }
    for (; p < p1; ++p) SetLanes(p, s0, s1);
  }

 private:
  // The scalar workspace of lane l, built when first needed (most batches need none).
  Data& Scalar(int l) {
    if (!scalar_[l]) scalar_[l].emplace(model_);
    return *scalar_[l];
  }

  WrenchResult& Result(long p, long s) {
    return results_[p * static_cast<long>(stiffness_.size()) + s];
  }

  // Postures p .. p + lanes - 1 in lanes 0 .. lanes - 1 (the last repeated in padding lanes).
  void PostureLanes(long p, int lanes, long s0, long s1) {
    const double* q[kLanes];
    const double* first = postures_.data() + p * postures_.outerStride();
    for (int l = 0; l < kLanes; ++l)
      q[l] = first + std::min(l, lanes - 1) * postures_.outerStride();
    const unsigned scalar_lanes = LaneKinematics(model_, lanes_, q, muscle_, activation_);
    SolveGroup(p, lanes, s0, s1, scalar_lanes);
  }

  // Groups g = 0 .. groups - 1 of four postures from p: each group's kinematics into its place
  // in the store, the muscle's force at all their lengths by one TensionBlock (the lengths
  // sorted into lane groups: fewer samples waiting for a group's slowest lane, more shared
  // curve segments; docs/performance.md), then each group's force stage and statics.
  void BlockLanes(const FastMuscle& mu, long p, long groups, long s0, long s1) {
    const std::size_t size = LaneGroupSize(lanes_);
    if (!store_) store_.reset(new Quad[kBlockGroups * size / 4]);  // (not zeroed: written first)
    unsigned scalar_lanes[kBlockGroups];
    double length[kBlockGroups * kLanes], force[kBlockGroups * kLanes];
    MuscleForceStatus status[kBlockGroups * kLanes];
    for (long g = 0; g < groups; ++g) {
      const double* q[kLanes];
      const double* first = postures_.data() + (p + g * kLanes) * postures_.outerStride();
      for (int l = 0; l < kLanes; ++l) q[l] = first + l * postures_.outerStride();
      LaneStore(lanes_, reinterpret_cast<double*>(store_.get()) + g * size);
      scalar_lanes[g] = LaneKinematics(model_, lanes_, q, muscle_, activation_, false);
      LaneLengths(lanes_, length + g * kLanes);
    }
    mu.force_model.TensionBlock(length, groups * kLanes, activation_, force, status);
    for (long g = 0; g < groups; ++g) {
      LaneStore(lanes_, reinterpret_cast<double*>(store_.get()) + g * size);
      const unsigned scalar =
          scalar_lanes[g] |
          LaneApplyForce(lanes_, force + g * kLanes, status + g * kLanes, scalar_lanes[g]);
      SolveGroup(p + g * kLanes, kLanes, s0, s1, scalar);
    }
    LaneStore(lanes_, nullptr);
  }

  // The statics of postures p .. p + lanes - 1 after their kinematics in the lanes, the lanes
  // `scalar_lanes` on the scalar path.
  void SolveGroup(long p, int lanes, long s0, long s1, unsigned scalar_lanes) {
    bool scalar_ready[kLanes] = {false, false, false, false};
    WrenchResult* out[kLanes];
    const long sets_per_posture = static_cast<long>(stiffness_.size());
    for (long s = s0; s < s1; ++s) {
      if (!valid_[static_cast<size_t>(s)]) {
        for (int l = 0; l < lanes; ++l) Result(p + l, s) = WrenchResult{};
        continue;
      }
      const StiffnessSet* set = &stiffness_[static_cast<size_t>(s)];
      const StiffnessSet* sets[kLanes] = {set, set, set, set};
      WrenchResult* result = &Result(p, s);
      for (int l = 0; l < kLanes; ++l)
        out[l] = l < lanes ? result + l * sets_per_posture : &padding_;
      const unsigned undecided = LaneSolve(model_, lanes_, sets, options_, out) & ~scalar_lanes;
      if (undecided == 0) continue;
      for (int l = 0; l < lanes; ++l) {
        if (undecided & (1u << l)) {
          if (!scalar_ready[l]) {
            ComputeKinematics(model_, Scalar(l), postures_.col(p + l), muscle_, activation_);
            scalar_ready[l] = true;
          }
          Result(p + l, s) = SolveStatics(model_, Scalar(l), stiffness_[s], options_);
        }
      }
    }
    // Lanes the kinematics handed back (last: SetLanes reuses the lane workspace).
    if (scalar_lanes == 0) return;
    for (int l = 0; l < lanes; ++l) {
      if (scalar_lanes & (1u << l)) SetLanes(p + l, s0, s1);
    }
  }

  // One posture, its kinematics broadcast to every lane, kLanes stiffness sets at a time.
  void SetLanes(long p, long s0, long s1) {
    Data& ws = Scalar(0);
    if (!ComputeKinematics(model_, ws, postures_.col(p), muscle_, activation_)) {
      for (long s = s0; s < s1; ++s) Result(p, s) = WrenchResult{};
      return;
    }
    // One stiffness set (a sweep, a fit's predictions): the scalar solve, as Evaluate; the lanes
    // would solve four copies of it (docs/performance.md "Wrapping muscles").
    long valid_sets = 0;
    for (long s = s0; s < s1 && valid_sets < 2; ++s) valid_sets += valid_[static_cast<size_t>(s)];
    if (valid_sets < 2) {
      for (long s = s0; s < s1; ++s) {
        Result(p, s) = valid_[static_cast<size_t>(s)]
                           ? SolveStatics(model_, ws, stiffness_[static_cast<size_t>(s)], options_)
                           : WrenchResult{};
      }
      return;
    }
    LaneBroadcast(ws, lanes_);
    long group[kLanes];
    int filled = 0;
    auto flush = [&] {
      const StiffnessSet* sets[kLanes];
      WrenchResult* out[kLanes];
      for (int l = 0; l < kLanes; ++l) {
        const int from = std::min(l, filled - 1);  // padding lanes repeat the last set
        sets[l] = &stiffness_[group[from]];
        out[l] = l < filled ? &Result(p, group[l]) : &padding_;
      }
      const unsigned undecided = LaneSolve(model_, lanes_, sets, options_, out);
      for (int l = 0; l < filled; ++l) {
        if (undecided & (1u << l))
          Result(p, group[l]) = SolveStatics(model_, ws, stiffness_[group[l]], options_);
      }
      filled = 0;
    };
    for (long s = s0; s < s1; ++s) {
      if (!valid_[static_cast<size_t>(s)]) {
        Result(p, s) = WrenchResult{};
        continue;
      }
      group[filled++] = s;
      if (filled == kLanes) flush();
    }
    if (filled > 0) flush();
  }

  const Model& model_;
  const Eigen::Ref<const Eigen::MatrixXd>& postures_;
  const int muscle_;
  const std::vector<StiffnessSet>& stiffness_;
  const std::vector<char>& valid_;
  const double activation_;
  const SolveOptions& options_;
  WrenchResult* const results_;
  LaneWorkspace lanes_;
  struct alignas(32) Quad {
    double v[4];
  };
  std::unique_ptr<Quad[]> store_;  // BlockLanes' groups' J and tau (LaneStore), when needed
  std::optional<Data> scalar_[kLanes];
  WrenchResult padding_;
};

}  // namespace

void EvaluateBatch(const Model& model, const Eigen::Ref<const Eigen::MatrixXd>& postures,
                   int muscle, const std::vector<StiffnessSet>& stiffness,
                   std::vector<WrenchResult>& out, double activation, const BatchOptions& options) {
  const int m = model.dof_count();
  if (postures.rows() != m) {
    throw Error("EvaluateBatch: postures have " + std::to_string(postures.rows()) +
                " rows; model '" + model.name() + "' has " + std::to_string(m) + " joints");
  }
  {
    // One vectorised pass over the whole matrix when its columns are contiguous, then a search
    // for the culprit only if there is one.
    bool any = false;
    if (postures.outerStride() == m) {
      any =
          AnyNonFinite(postures.data(), static_cast<long>(m) * static_cast<long>(postures.cols()));
    } else {
      for (Eigen::Index p = 0; p < postures.cols(); ++p)
        any |= AnyNonFinite(postures.col(p).data(), m);
    }
    if (any) {
      for (Eigen::Index p = 0; p < postures.cols(); ++p) {
        if (!postures.col(p).allFinite()) {
          throw Error("EvaluateBatch: posture " + std::to_string(p) + " has a non-finite entry");
        }
      }
    }
  }
  if (muscle < 0 || muscle >= model.muscle_count()) {
    throw Error("EvaluateBatch: muscle index " + std::to_string(muscle) +
                " is out of range (model '" + model.name() + "' has " +
                std::to_string(model.muscle_count()) + " muscles)");
  }
  if (stiffness.empty()) throw Error("EvaluateBatch: no stiffness set given");
  for (size_t s = 0; s < stiffness.size(); ++s) {
    if (stiffness[s].s_p.size() != m) {
      throw Error("EvaluateBatch: stiffness set " + std::to_string(s) + " has " +
                  std::to_string(stiffness[s].s_p.size()) + " S_p entries for " +
                  std::to_string(m) + " joints");
    }
  }
  // Every force model (the constant one too) takes activations in [0, 1] only: checked once
  // here, before the threads (a force model's MuscleForceModel::Evaluate would throw inside
  // them; a constant-force muscle would scale the wrench by it silently).
  try {
    static_cast<void>(MuscleForceAt(model, muscle, 1.0, activation));
  } catch (const Error& e) {
    throw Error(std::string("EvaluateBatch: ") + e.what());
  }
  const long P = static_cast<long>(postures.cols());
  const long S = static_cast<long>(stiffness.size());
  const long total = P * S;
  out.resize(static_cast<size_t>(total));  // every entry is written below
  if (P == 0) {
    if (options.progress) options.progress(0, 0);
    return;
  }
  std::vector<char> valid(stiffness.size());
  for (size_t s = 0; s < stiffness.size(); ++s) valid[s] = ValidStiffness(stiffness[s]);

  // Units: posture blocks, and set blocks when the posture blocks alone are too few.
  const long threads_wanted = std::max(1, options.threads);
  // (BlockLanes runs on a small chain only: LaneGroupSize)
  const bool block_force = !model.impl().flat.large &&
                           BlockForceStage(model.impl().flat.muscles[static_cast<size_t>(muscle)]);
  const long wanted_units = threads_wanted * (block_force ? kBlockUnitsPerThread : kUnitsPerThread);
  const long posture_block =
      std::clamp<long>(RoundUpToLanes((P + wanted_units - 1) / wanted_units), kLanes,
                       block_force ? kMaxBlockPostures : kMaxPostureBlock);
  const long posture_units = (P + posture_block - 1) / posture_block;
  long set_block = S;
  if (posture_units < wanted_units) {
    const long set_units_wanted = (wanted_units + posture_units - 1) / posture_units;
    set_block =
        std::max<long>(kLanes, RoundUpToLanes((S + set_units_wanted - 1) / set_units_wanted));
  }
  const long set_units = (S + set_block - 1) / set_block;
  const long units = posture_units * set_units;
  const int threads = static_cast<int>(std::clamp<long>(threads_wanted, 1, units));
  std::atomic<long> next_unit{0};
  std::atomic<long> done{0};
  WrenchResult* results = out.data();

  auto work = [&](bool report) {
    UnitEvaluator evaluator(model, postures, muscle, stiffness, valid, activation, options.solve,
                            results);
    for (;;) {
      const long unit = next_unit.fetch_add(1, std::memory_order_relaxed);
      if (unit >= units) break;
      const long p0 = unit / set_units * posture_block, p1 = std::min(P, p0 + posture_block);
      const long s0 = unit % set_units * set_block, s1 = std::min(S, s0 + set_block);
      evaluator.Run(p0, p1, s0, s1);
      const long count = (p1 - p0) * (s1 - s0);
      const long total_done = done.fetch_add(count, std::memory_order_relaxed) + count;
      if (report && options.progress) options.progress(total_done, total);
    }
  };
  std::vector<std::thread> helpers;
  helpers.reserve(static_cast<size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) helpers.emplace_back(work, false);
  work(true);
  for (std::thread& t : helpers) t.join();
  if (options.progress) options.progress(total, total);
}

}  // namespace isowrench
