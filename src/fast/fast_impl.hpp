#pragma once
// Private: the buffers of Data and the kinematics kernel every evaluation runs.
//
// A Data's workspace has one of two shapes, chosen from its model (FlatChain::large):
//  - SmallWorkspace: fixed-size arrays inside the workspace (kSmallJoints movable joints and
//    columns, kSmallSlots slots, kSmallPoints path points), so that every stride and offset the
//    kernel uses is a compile-time constant (the small chains' speed: docs/performance.md);
//  - LargeWorkspace: buffers sized from the chain, in one allocation made when the Data is
//    built, with the strides as run-time numbers: any number of joints, columns and points.
// Both derive from Data::Impl, whose views (Buffer) show the results to the code outside the
// kernel (the public accessors, the kinematics functions, the moving path points). The kernel
// (kernel.hpp) and the statics (fast.cpp) are templates over the shape; each evaluation picks
// the instantiation of its chain's shape. Neither kind ever allocates after construction.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "fast/vec3.hpp"
#include "isowrench/engine.hpp"
#include "model/model_impl.hpp"

namespace isowrench {

/// The force stage: muscle `mu`'s force model at path length `length` (m) and `activation`:
/// the one definition of F(L_MT, a) every evaluation and report uses (MuscleForceAt, engine.hpp).
/// @throws Error for an activation outside [0, 1].
inline MuscleForce MuscleForceOf(const FastMuscle& mu, double length, double activation) {
  return mu.force_model.Evaluate(length, activation);
}

/// MuscleForceOf(mu, length, activation).force and .status, bit for bit, without the other
/// fields (MuscleForceModel::Tension): the kernels' force stage.
/// @throws Error for an activation outside [0, 1].
inline double MuscleTensionOf(const FastMuscle& mu, double length, double activation,
                              MuscleForceStatus* status) {
  return mu.force_model.Tension(length, activation, status);
}

/// MuscleTensionOf of four lengths (MuscleForceModel::Tension4, the same bits): the batch
/// lanes' force stage.
/// @throws Error for an activation outside [0, 1].
inline void MuscleTensionsOf(const FastMuscle& mu, const double length[4], double activation,
                             double force[4], MuscleForceStatus status[4]) {
  mu.force_model.Tension4(length, activation, force, status);
}

/// A path segment shorter than this (m) has no direction (same rule as ComputeMuscleTorque).
inline constexpr double kFastMinSegmentLength = 1e-9;

/// n entries of T that a workspace owns (a fixed-size array of a SmallWorkspace, or part of a
/// LargeWorkspace's one allocation, WorkspaceArena): a view, set once when the workspace is
/// built and never resized.
template <class T>
class Buffer {
 public:
  Buffer() = default;
  Buffer(T* data, std::size_t size) : data_(data), size_(size) {}
  T* data() const { return data_; }
  std::size_t size() const { return size_; }
  T& operator[](std::size_t i) const { return data_[i]; }
  T* begin() const { return data_; }
  T* end() const { return data_ + size_; }

 private:
  friend class WorkspaceArena;
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

/// One zeroed, 32-byte aligned allocation carved into the Buffers of a LargeWorkspace. The
/// workspace lays its buffers out twice with Take: first to count the bytes, then, after
/// Allocate, to place them.
class WorkspaceArena {
 public:
  template <class T>
  void Take(Buffer<T>& buffer, std::size_t n) {
    if (memory_ != nullptr) {
      buffer.data_ = reinterpret_cast<T*>(memory_.get() + used_);
      buffer.size_ = n;
      if constexpr (!std::is_trivially_default_constructible_v<T>) {
        std::uninitialized_default_construct_n(buffer.data_, n);  // (zero bytes: zero values)
      }
    }
    used_ += (n * sizeof(T) + 31) / 32 * 32;
  }
  /// After the counting pass: the memory, zeroed; the next pass places the buffers.
  void Allocate() {
    const std::size_t bytes = std::max<std::size_t>(used_, 32);
    memory_.reset(static_cast<unsigned char*>(::operator new(bytes, std::align_val_t(32))));
    std::memset(memory_.get(), 0, bytes);
    used_ = 0;
  }

 private:
  struct Free {
    void operator()(unsigned char* p) const { ::operator delete(p, std::align_val_t(32)); }
  };
  std::unique_ptr<unsigned char[], Free> memory_;
  std::size_t used_ = 0;
};

/// How big a workspace is: movable joints, columns, the stride (FlatChain::stride), slots, the
/// most path points and moving components of a muscle, and its shape (FlatChain::large).
struct WorkspaceSize {
  int joints = 0, columns = 0, stride = 0, slots = 0, points = 0, moving = 0;
  bool large = false;
  static WorkspaceSize Of(const FlatChain& d) {
    return {d.m, d.n, d.stride, d.slot_count, d.max_points, d.max_moving, d.large};
  }
  /// The workspace of the raw-matrix solve (Data(int)): no joints, no points.
  static WorkspaceSize Raw(int columns) {
    const bool large = columns > kSmallJoints;
    return {0,
            columns,
            large ? RoundUpTo4(columns) : kSmallJoints,
            large ? RoundUpTo4(columns) : kSmallSlots,
            0,
            0,
            large};
  }
  /// True when a workspace of this size can run chain d: the same shape, columns and stride,
  /// and room for its joints, slots and points.
  bool Holds(const FlatChain& d) const {
    return d.large == large && d.n == columns && d.stride == stride && d.m <= joints &&
           d.slot_count <= slots && d.max_points <= points && d.max_moving <= moving;
  }
};

/// The buffers of a wrapped muscle's path (src/fast/path_points.cpp, WrappedPathPulls): the input
/// of ComputeWrappedPath for the last wrapped muscle evaluated (its constant parts, the wraps'
/// surfaces and ranges, copied when another muscle comes), and its result. A Data of a model
/// with wraps makes it at construction; after the first evaluation of a muscle, further
/// evaluations of it do not allocate.
struct WrapWorkspace {
  std::uint64_t chain_id = 0;          ///< FlatChain::id of `muscle`
  const FastMuscle* muscle = nullptr;  ///< whose wraps `input` holds
  WrapPathInput input;
  WrappedPath path;  ///< the last wrapped muscle's path (points and tangent points in world)
};

/// The part of the scalar workspace that every shape has, and the views of the results for the
/// code outside the kernel (src/fast/kernel.hpp describes what the kernel needs; it reads the
/// derived shapes' own arrays, SmallWorkspace hiding these views by the same names).
struct Data::Impl {
  using Scalar = double;
  Impl(const WorkspaceSize& size, const FlatChain* chain);
  virtual ~Impl();
  Impl(const Impl&) = delete;  // the views point into the derived object's buffers
  Impl& operator=(const Impl&) = delete;
  /// The FlatChain::id and name of the model this workspace was made for (0 and "": Data(int));
  /// another chain is checked against `size` first (CheckWorkspace, fast.cpp).
  std::uint64_t chain_id = 0;
  std::string model_name;
  WorkspaceSize size;
  int m = 0;  ///< the columns: the statics' m (the model's coordinates)
  /// Kinematics of the last posture (Vec3: x, y, z in one SIMD vector, fast/vec3.hpp): per
  /// movable joint its world axis and origin (a point on the axis); per path point of the
  /// muscle its world position and pull dL/dx (a sum of unit segment directions). World
  /// rotation (three columns) of the frame after each movable joint, written only by the kernel
  /// with frames (the public kinematics functions). Coupled chains: each movable joint's
  /// position q_joint = f(q_c), and dq_joint/dq_c of the driven joints.
  Buffer<Vec3<double>> origin, axis, points, pulls;
  Buffer<std::array<Vec3<double>, 3>> frames;
  Buffer<double> q_joint, dq_joint;
  /// The endpoint (pose[0]) and the columns of R_W_T (pose[1 .. 3]), as the kernel stores them.
  Vec3<double> pose[4] = {};
  void SetPose(const Vec3<double>& endpoint, const Vec3<double>* R_W_T) {
    pose[0] = endpoint;
    for (int c = 0; c < 3; ++c) pose[1 + c] = R_W_T[c];
  }
  Eigen::Vector3d Endpoint() const { return ToEigen(pose[0]); }
  Eigen::Matrix3d TransducerRotation() const { return ToEigen(pose + 1); }
  Eigen::Matrix3d Frame(int k) const { return ToEigen(frames[k].data()); }
  /// The storage behind Data::endpoint_position() and Data::transducer_rotation(), filled only
  /// by those calls: never read them directly (call Endpoint() / TransducerRotation()).
  mutable Eigen::Vector3d endpoint_copy = Eigen::Vector3d::Zero();
  mutable Eigen::Matrix3d R_W_T_copy = Eigen::Matrix3d::Identity();
  /// The endpoint Jacobian as the kernel writes it: row-major with the row stride
  /// size.stride (row r at Jr + r * stride, columns 0 .. m - 1), the layout the statics reads
  /// rows of; the entries from m to the stride stay 0.
  Buffer<double> Jr;
  /// dL/dq, tau and dtheta (m entries; the buffers hold the stride: the kernel and the solve
  /// read and write whole 4-double vectors).
  Buffer<double> dL_data, tau_data, dtheta_data;
  Eigen::Map<Eigen::VectorXd> dL{nullptr, 0};
  Eigen::Map<Eigen::VectorXd> tau{nullptr, 0};
  Eigen::Map<Eigen::VectorXd> dtheta{nullptr, 0};
  double length = 0.0;
  /// The force stage's result of the last kinematics of a muscle with a force model
  /// (FastMuscle::force_curve; not written for a constant-force muscle): F (N) and its status
  /// (MuscleTensionOf; MuscleForceAt gives every field).
  double force = 0.0;
  MuscleForceStatus force_status = MuscleForceStatus::kNoEquilibrium;
  /// J, dL and tau have the m columns of the model from construction on (the kernel asks for
  /// its chain's n, which is m).
  void Resize([[maybe_unused]] int n) const { assert(n == m); }
  /// J (6 x m) as a matrix: Data::jacobian(), copied from Jr on each call.
  const JacobianBuffer& Jacobian() const {
    const int s = size.stride;
    for (int c = 0; c < m; ++c) {
      for (int r = 0; r < 6; ++r) J(r, c) = Jr[static_cast<std::size_t>(r * s + c)];
    }
    return J;
  }
  /// Sets J (6 x m): Jr from a matrix of m columns.
  template <class Matrix>
  void SetJacobian(const Matrix& jacobian) {
    assert(jacobian.cols() == m);
    const int s = size.stride;
    for (int c = 0; c < m; ++c) {
      for (int r = 0; r < 6; ++r) Jr[static_cast<std::size_t>(r * s + c)] = jacobian(r, c);
    }
  }
  mutable JacobianBuffer J;  // Jacobian()'s copy
  /// The self-motion basis of the last solve: m x self_motion_count, column-major in an
  /// m x m buffer.
  Buffer<double> self_motion_data;
  int self_motion_count = 0;
  /// Muscles with moving or conditional points (FastMuscle::dynamic), from PreparePathPoints:
  /// each point's position in its frame, the active points in path order, per moving
  /// component df/dq (0 where the coordinate is clamped); the kernel adds each point's frame
  /// rotation in world.
  Buffer<Eigen::Vector3d> local;
  Buffer<std::array<Vec3<double>, 3>> point_rotation;
  Buffer<int> active;
  int active_count = 0;
  Buffer<double> moving_slope;
  /// SetPathPointOffsets (engine.hpp): the muscle whose path points are moved (-1: none) and
  /// this Data's copy of it (muscle `moved_index` of chain `moved_chain`), its path points at
  /// the model's positions plus the offsets (turned into each point's kernel frame by
  /// `offset_rotations`, the link frame -> kernel frame rotations of FlatChain::links, fixed
  /// joints folded in). EvaluatedMuscle picks it: the kernel, the moving points, the wraps and
  /// the force stage then run on the copy as on the model's muscle.
  int offset_muscle = -1;
  std::uint64_t moved_chain = 0;
  int moved_index = -1;
  std::unique_ptr<FastMuscle> moved_muscle;
  std::vector<Eigen::Matrix3d> offset_rotations;
  /// Muscles with wraps (FastMuscle::wraps): their path's buffers (made with the Data when its
  /// model has a wrap, else at the first wrapped muscle).
  std::unique_ptr<WrapWorkspace> wrap;

 protected:
  /// Called by the derived constructors once their buffers exist: the Maps over them.
  void SetViews();
};

/// The fixed-size workspace of a small chain (FlatChain::large false): every array inside the
/// object, so that the kernel addresses them at constant offsets with constant strides. Its
/// arrays hide Data::Impl's views of the same names (which point at them).
struct SmallWorkspace final : Data::Impl {
  static constexpr bool kLarge = false;
  /// J's and U's row stride, and the staging's offsets (v, w and the terms of dL/dq of slot s
  /// at staged[s], staged[kW + s], staged[kP + s]).
  static constexpr int kStride = kSmallJoints;
  static constexpr int kW = kSmallSlots, kP = 2 * kSmallSlots;
  SmallWorkspace(const WorkspaceSize& size, const FlatChain* chain);
  std::array<Vec3<double>, kSmallJoints> origin;
  std::array<Vec3<double>, kSmallJoints> axis;
  std::array<Vec3<double>, kSmallPoints> points;
  std::array<Vec3<double>, kSmallPoints> pulls;
  std::array<std::array<Vec3<double>, 3>, kSmallJoints> frames;
  std::array<double, kSmallJoints> q_joint;
  std::array<double, kSmallJoints> dq_joint;
  /// One posture stages the Jacobian columns [v; w] (world axes) and the x, y, z terms of
  /// dL/dq_c here (see kW, kP); kernel::FinishColumns moves the first m columns into Jr, dL and
  /// tau, four at a time (the columns from m to the next multiple of 4 are 0 from construction
  /// on).
  Vec3<double> staged[3 * kSmallSlots];
  alignas(32) std::array<double, 6 * kStride> Jr;
  std::array<double, kStride> dL_data, tau_data, dtheta_data;
  // Statics.
  // Cholesky factor of K, K = U^T U: row k at U + k * kStride, its strict upper part U_ki
  // (i > k) read; the entries from 4 floor(k / 4) to k hold leftovers of the vector row updates
  // (U_kk included: the reciprocal diagonal is kept apart) and are never read.
  std::array<double, kStride * kStride> U;
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kStride, kStride>;
  Matrix K_full;
  Eigen::SelfAdjointEigenSolver<Matrix> eigen;
  std::array<double, kStride * kStride> self_motion_data;
  std::array<Eigen::Vector3d, kSmallPoints> local;
  std::array<std::array<Vec3<double>, 3>, kSmallPoints> point_rotation;
  std::array<int, kSmallPoints> active;
  std::array<double, 3 * kSmallPoints> moving_slope;
};

/// The workspace of a large chain (FlatChain::large): Data::Impl's views and the kernel's own
/// buffers, all in one allocation sized from the chain; strides and offsets are run-time
/// numbers.
struct LargeWorkspace final : Data::Impl {
  static constexpr bool kLarge = true;
  LargeWorkspace(const WorkspaceSize& size, const FlatChain* chain);
  void Lay(WorkspaceArena& arena);
  WorkspaceArena arena;
  int kStride = 0;     ///< J's and U's row stride (FlatChain::stride)
  int kW = 0, kP = 0;  ///< the staging's offsets (the slots, twice the slots)
  Buffer<Vec3<double>> staged;
  /// sin q_k of the joints at trig[k], cos q_k at trig[cos_offset + k] (kernel::JointSinCos
  /// writes whole vectors).
  Buffer<double> trig;
  int cos_offset = 0;
  Buffer<double> U;
  /// The statics' copies (S_t J; J, tau and S_p with the locked columns taken out; a raw
  /// solve's S_p) and the Cholesky's scratch (the reciprocal diagonal, the forward
  /// substitution), which a small chain keeps on the stack.
  Buffer<double> sJ, locked_J, locked_tau, s_p_copy;
  Buffer<double> inv_diag_scratch, y_scratch;
  Eigen::MatrixXd K_full;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen;
};

/// The muscle an evaluation of muscle `muscle` (>= 0) of chain `d` runs: the model's, or the
/// Data's copy with its path points moved (SetPathPointOffsets). One comparison when no
/// offsets are set (offset_muscle -1); a Data holding offsets for another model's muscle
/// (CheckWorkspace lets a Data run a chain it can hold) uses the model's.
inline const FastMuscle& EvaluatedMuscle(const FlatChain& d, const Data::Impl& ws, int muscle) {
  if (__builtin_expect(ws.offset_muscle == muscle, 0) && ws.moved_chain == d.id)
    return *ws.moved_muscle;
  return d.muscles[static_cast<std::size_t>(muscle)];
}

/// Moving and conditional path points (src/fast/path_points.cpp), for a muscle with
/// FastMuscle::dynamic. Before the kernel: each point's position in its frame (ws.local), the
/// active points (ws.active) and df/dq of each moving component at coordinates `q` (columns).
void PreparePathPoints(const FastMuscle& muscle, const double* q, Data::Impl& ws);
/// The kernel's segment step over the active points only: unit directions, pulls (0 at
/// inactive points) and the length. Returns false when two consecutive active points coincide.
bool ActivePathPulls(Data::Impl& ws, double* length);
/// The same for a muscle with wraps (chain: the muscle's, for WrapWorkspace): the wrapped path
/// (ComputeWrappedPath in the muscle's WrapMode) over the active points, whose pulls it writes,
/// and each wrap's tangent points and pulls into its two slots (zero pulls when it does not
/// wrap); the slots' positions and frame rotations on entry give X_W_S. Returns false when two
/// consecutive active points coincide.
bool WrappedPathPulls(const FlatChain& chain, const FastMuscle& muscle, Data::Impl& ws,
                      double* length);
/// ActivePathPulls, or WrappedPathPulls for a muscle with wraps (the kernel's kDynamic step).
inline bool DynamicPathPulls(const FlatChain& chain, const FastMuscle& muscle, Data::Impl& ws,
                             double* length) {
  if (muscle.wraps.empty()) return ActivePathPulls(ws, length);
  return WrappedPathPulls(chain, muscle, ws, length);
}
/// After the kernel (dL and tau in coordinate columns): dL/dq_c += pull_i . R_i direction df/dq_c
/// for every moving component, and tau = minus_force dL.
void AddMovingPointTerms(const FastMuscle& muscle, Data::Impl& ws, double minus_force);

/// The kinematics kernel of ComputeKinematics with every movable joint's world rotation
/// stored in ws.frames, for the public kinematics functions. `muscle` < 0: no muscle (dL and
/// tau zero). `world_axes`: J in world axes instead of transducer axes. Returns false when two
/// consecutive path points coincide (as ComputeKinematics). q: chain.n coordinates.
/// @throws Error when `ws` was made for a chain it cannot hold (see Data).
bool ComputeKinematicsWithFrames(const FlatChain& chain, Data::Impl& ws, const double* q,
                                 int muscle, double activation, bool world_axes);

}  // namespace isowrench
