// Proof that the fast path does not allocate: global operator new is replaced in this test
// binary by a counting version, and the count must not move across many evaluations after the
// workspace is built (regular K, singular K through the eigen fallback, raw-matrix solves).

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <random>

#include "fast/large_chain.hpp"
#include "isowrench/isowrench.hpp"
#include "model/model_impl.hpp"

// The replacements below allocate with malloc and free with free, on purpose; g++ 12, seeing
// them inlined into this file's own allocations (the large chain's description), takes the
// pair for a mismatch.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, std::align_val_t alignment) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = static_cast<std::size_t>(alignment);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return operator new(size, alignment);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(FastAllocation, CounterSeesAllocations) {
  // The counter works: a vector allocation is counted (so zero below means zero).
  const long before = g_allocations.load();
  // (through a volatile pointer: g++ may elide a new/delete pair it sees whole, C++14)
  std::vector<double>* volatile v = new std::vector<double>(100);
  delete v;
  EXPECT_GE(g_allocations.load() - before, 2);
}

TEST(FastAllocation, EvaluationsAllocateNothingAfterWarmUp) {
  using namespace isowrench;
  const Model model =
      Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof_base.urdf");
  const Model rat6 =
      Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_6dof.urdf");
  Data ws(model), ws6(rat6), raw(3);
  const StiffnessSet stiffness = model.model_stiffness(), stiffness6 = rat6.model_stiffness();
  constexpr int kN = 2000;
  Eigen::MatrixXd postures(model.dof_count(), kN);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  for (int p = 0; p < kN; ++p) {
    for (int i = 0; i < model.dof_count(); ++i) {
      postures(i, p) =
          model.joint(i).type == JointType::kPrismatic ? 0.001 * angle(rng) : angle(rng);
    }
  }
  Eigen::VectorXd straight = rat6.nominal_posture();
  straight[rat6.JointIndex("knee_rz")] = 0.0;  // singular K, held self-motion (eigen fallback)
  Matrix6Xd J = Matrix6Xd::Zero(6, 3);
  J.col(0) << 1, 0, 2, 0, 1, 0;
  J.col(1) = J.col(0);
  J.col(2) << 0, 1, 0, 3, 1, 0;
  const Vector6d s_t = Vector6d::Constant(10.0);
  const Eigen::VectorXd s_p = Eigen::VectorXd::Zero(3);
  const Eigen::Vector3d tau(0.7, 0.7, -0.2);

  // Warm-up: anything lazily initialised (libm tables, ...) happens here.
  Evaluate(model, ws, postures.col(0), 0, stiffness);
  Evaluate(rat6, ws6, straight, 0, stiffness6);
  SolveStatics(raw, J, s_t, s_p, tau);

  const long before = g_allocations.load();
  double checksum = 0.0;
  int held = 0;
  for (int p = 0; p < kN; ++p) {
    checksum += Evaluate(model, ws, postures.col(p), 0, stiffness).wrench.sum();
    held += Evaluate(rat6, ws6, straight, 0, stiffness6).status == StaticsStatus::kSelfMotionHeld;
    checksum += SolveStatics(raw, J, s_t, s_p, tau).wrench.sum();
  }
  const long allocations = g_allocations.load() - before;
  EXPECT_EQ(allocations, 0) << "allocations in " << 3 * kN << " evaluations";
  EXPECT_EQ(held, kN);  // the fallback path really ran
  EXPECT_TRUE(std::isfinite(checksum));
}

// A muscle over a wrap object (issue 27): the knee_wrap leg of tests/wrap/data, in both wrap
// modes, over postures where the cylinder wraps and where it does not, and alternating with the
// straight muscle (the wrap workspace keeps its buffers).
TEST(FastAllocation, WrappedMuscleEvaluationsAllocateNothingAfterWarmUp) {
  using namespace isowrench;
  LimbDescription d = ReadUrdfFile(std::string(ISOWRENCH_TEST_WRAP_URDF));
  const Model opensim(d);
  d.wrap_mode = WrapMode::kExact;
  const Model exact(d);
  Data ws(opensim), ws_exact(exact);
  const StiffnessSet stiffness = opensim.model_stiffness();
  constexpr int kN = 400;
  Eigen::MatrixXd postures(2, kN);
  for (int p = 0; p < kN; ++p) postures.col(p) << 0.3, -2.4 + 4.8 * p / (kN - 1);
  for (int p = 0; p < kN; ++p) {  // warm-up: the buffers grow to the longest path once
    Evaluate(opensim, ws, postures.col(p), 0, stiffness);
    Evaluate(exact, ws_exact, postures.col(p), 0, stiffness);
  }
  const long before = g_allocations.load();
  double checksum = 0.0;
  for (int p = 0; p < kN; ++p) {
    checksum += Evaluate(opensim, ws, postures.col(p), 0, stiffness).wrench.sum();
    checksum += Evaluate(opensim, ws, postures.col(p), 1, stiffness).wrench.sum();
    checksum += Evaluate(exact, ws_exact, postures.col(p), 0, stiffness).wrench.sum();
  }
  EXPECT_EQ(g_allocations.load() - before, 0) << "allocations in " << 3 * kN << " evaluations";
  EXPECT_TRUE(std::isfinite(checksum));
}

// The same on a large chain (66 movable joints, 33 coordinates: the workspace's buffers sized
// from the model, the Cholesky's rows in its scratch): regular K, a locked coordinate (the
// statics' copies of J, tau and S_p), singular K through the eigen fallback, ComputeKinematics
// then SolveStatics, and a raw-matrix solve of 20 columns.
TEST(FastAllocation, LargeChainEvaluationsAllocateNothingAfterWarmUp) {
  using namespace isowrench;
  const Model model = large_chain::Model({33, true, 0, false});
  isowrench::LimbDescription locked_description = model.description();
  locked_description.coordinates[5].locked = true;
  const Model locked(locked_description);
  ASSERT_TRUE(model.impl().flat.large);
  Data ws(model), ws_locked(locked), raw(20);
  const StiffnessSet stiffness = model.model_stiffness();
  StiffnessSet singular = stiffness;
  singular.s_p.setZero();
  constexpr int kN = 200;
  Eigen::MatrixXd postures(model.dof_count(), kN);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> angle(-2.5, 2.5);
  for (int p = 0; p < kN; ++p) {
    for (int i = 0; i < model.dof_count(); ++i) postures(i, p) = angle(rng);
  }
  Matrix6Xd J = Matrix6Xd::Zero(6, 20);
  for (int c = 0; c < 20; ++c) J.col(c) << 1, 0.1 * c, 2, 0, 1, -0.05 * c;
  const Vector6d s_t = Vector6d::Constant(10.0);
  const Eigen::VectorXd s_p = Eigen::VectorXd::Constant(20, 0.5);
  const Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(20, -1.0, 1.0);

  Evaluate(model, ws, postures.col(0), 0, stiffness);
  Evaluate(model, ws, postures.col(0), 0, singular);
  Evaluate(locked, ws_locked, postures.col(0), 1, locked.model_stiffness());
  SolveStatics(raw, J, s_t, s_p, tau);

  const long before = g_allocations.load();
  double checksum = 0.0;
  int self_motion = 0;
  for (int p = 0; p < kN; ++p) {
    checksum += Evaluate(model, ws, postures.col(p), p % 2, stiffness).wrench.sum();
    self_motion += Evaluate(model, ws, postures.col(p), 0, singular).self_motion_count > 0;
    checksum +=
        Evaluate(locked, ws_locked, postures.col(p), 1, locked.model_stiffness()).wrench.sum();
    checksum += SolveStatics(raw, J, s_t, s_p, tau).wrench.sum();
    ComputeKinematics(model, ws, postures.col(p), 1);
    checksum += SolveStatics(model, ws, stiffness).wrench.sum();
  }
  const long allocations = g_allocations.load() - before;
  EXPECT_EQ(allocations, 0) << "allocations in " << 5 * kN << " evaluations";
  EXPECT_EQ(self_motion, kN);  // the eigen fallback really ran
  EXPECT_TRUE(std::isfinite(checksum));
}

}  // namespace
