// Uncertainty studies: inputs resolved against the model, the A/B/A_B^i design evaluated in
// fixed blocks through the engine, partial sums per block, and the statistics.

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <thread>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/io.hpp"
#include "isowrench/uncertainty.hpp"
#include "uncertainty/normal_quantile.hpp"
#include "uncertainty/percentiles.hpp"
#include "uncertainty/unc_math.hpp"

namespace isowrench {

namespace {

constexpr int kQ = kUncertaintyQuantities;
// A row's quantities are kept as kLanes doubles in "lane order", so that four quantities of a row
// are one 4-double vector: the Sobol quantities first (the reading, |f|, |m|, the angle: lanes
// 0-8), then the world axes (9-14), a pad (15). kLaneOf[q]: the lane of quantity q.
constexpr int kLanes = 16;
constexpr int kSobolLanes = 9;
constexpr int kLaneOf[kQ] = {0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 6, 7, 8};
// What Quantities says of a row's values: every lane but the angle's (and the pad) is finite
// (the world lanes only when they were computed); the angle is finite. When a flag is missing
// the sums below look at each value.
constexpr int kRowFinite = 1;
constexpr int kAngleFinite = 2;
constexpr int kAllFinite = kRowFinite | kAngleFinite;
constexpr double kPi = 3.14159265358979323846;
constexpr double kPercentileLevels[4] = {0.025, 0.5, 0.95, 0.975};

// A reading's quantities in lane order (kLaneOf) for one row (T = double) or four (T = 4
// doubles, unc_math.hpp): y[0..5] the reading W, y[6] |f|, y[7] |m|, y[8] the angle between f and
// the unit direction d (NaN when !has_direction or |f| = 0), y[9..14] the world axes R f, R m
// (R: R_W_T, column-major), y[15] = 0. Every operation in a fixed order, so a lane gives the
// scalar's bits.
template <class T>
inline void ReadingLaneQuantities(const T* W, const double* R, const double* d, bool has_direction,
                                  T* y) {
  for (int i = 0; i < 6; ++i) y[i] = W[i];
  for (int i = 0; i < 3; ++i) {
    y[9 + i] = (R[i] * W[0] + R[3 + i] * W[1]) + R[6 + i] * W[2];
    y[12 + i] = (R[i] * W[3] + R[3 + i] * W[4]) + R[6 + i] * W[5];
  }
  y[15] = T{};
  UncSqrt((W[0] * W[0] + W[1] * W[1]) + W[2] * W[2], y[6]);
  UncSqrt((W[3] * W[3] + W[4] * W[4]) + W[5] * W[5], y[7]);
  const T nan = T{} + std::numeric_limits<double>::quiet_NaN();
  if (!has_direction) {
    y[8] = nan;
    return;
  }
  const T c0 = W[1] * d[2] - W[2] * d[1], c1 = W[2] * d[0] - W[0] * d[2],
          c2 = W[0] * d[1] - W[1] * d[0];
  T cross, angle;
  UncSqrt((c0 * c0 + c1 * c1) + c2 * c2, cross);
  const T dot = (W[0] * d[0] + W[1] * d[1]) + W[2] * d[2];
  UncAtan2NonNegativeY(cross, dot, angle);
  y[8] = y[6] == 0.0 ? nan : angle;
}

const char* const kDofNames[6] = {"x", "y", "z", "rx", "ry", "rz"};
const char* const kAxisNames[6] = {"fx", "fy", "fz", "mx", "my", "mz"};

int AxisIndexOf(const std::string& name) {
  for (int k = 0; k < 6; ++k)
    if (name == kAxisNames[k]) return k;
  return -1;
}

// What a dimension of the input space changes.
enum class Target {
  kTransducerStiffness,  // index: dof
  kJointStiffness,       // columns
  kAngle,                // index: column
  kForceFactor,
  kActivation,
  kMisalignment,              // index: axis
  kGain,                      // index: reading axis
  kCrosstalk,                 // index: reading * 6 + source
  kCrosstalkSymmetric,        // index: a * 6 + b (both terms)
  kSensorOrigin,              // index: axis
  kSensorOffset,              // index: axis
  kTransducerRotationFactor,  // krx kry krz times the value
  kPointOffset,               // index: point * 3 + axis (the study's muscle, m)
  kNone,                      // sampled, changes nothing here (a fit parameter of another muscle)
};

struct Dimension {
  int group = 0;
  InputDistribution distribution = InputDistribution::kNormal;
  double a = 0.0, b = 0.0;   // normal: mean, sd; lognormal: median, sd; uniform: lower, upper;
                             // loguniform: ln lower, ln upper
  int fit_index = -1;        // >= 0: the fit's parameter (correlated, group "fit")
  bool log10_value = false;  // fit: value = 10^x
  double scale = 1.0;        // fit: value times this (deg -> rad, mm -> m)
  Target target = Target::kForceFactor;
  int index = 0;
  std::vector<int> columns;
  bool absolute = false;  // stiffness: the value itself (else a factor on the model's)
};

// The value a dimension takes at a standard normal z / uniform u (independent dimensions).
double IndependentValue(const Dimension& d, double u) {
  switch (d.distribution) {
    case InputDistribution::kNormal: return d.a + d.b * NormalQuantile(u);
    // exp: UncExp (unc_math.hpp), the same bits as the block draws' ExpValues.
    case InputDistribution::kLogNormal: return d.a * UncExp(0.0 + NormalQuantile(u) * d.b);
    case InputDistribution::kUniform: return d.a + u * (d.b - d.a);
    case InputDistribution::kLogUniform: return 1.0 * UncExp(d.a + u * (d.b - d.a));
  }
  return 0.0;
}

double CentralValue(const Dimension& d) {
  switch (d.distribution) {
    case InputDistribution::kNormal: return d.a;
    case InputDistribution::kLogNormal: return d.a;
    case InputDistribution::kUniform: return 0.5 * (d.a + d.b);
    case InputDistribution::kLogUniform: return UncExp(0.5 * (d.a + d.b));
  }
  return 0.0;
}

// Everything one row's inputs change.
struct RowInputs {
  StiffnessSet set;
  Eigen::VectorXd dq;
  double factor = 1.0;
  double activation = 1.0;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();
  Vector6d gain = Vector6d::Ones();
  Matrix6d crosstalk = Matrix6d::Zero();  // normalised Ê
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Vector6d offset = Vector6d::Zero();
  // Path point offsets of the study's muscle (m, each point's link frame; 3 x path points),
  // handed to the engine by SetPathPointOffsets (point inputs only).
  Eigen::Matrix3Xd points;
};

std::uint64_t Fnv(std::uint64_t h, const void* data, size_t size) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= 1099511628211ull;
  }
  return h;
}
std::uint64_t FnvString(std::uint64_t h, const std::string& s) {
  h = Fnv(h, s.data(), s.size());
  const std::uint64_t n = s.size();
  return Fnv(h, &n, sizeof n);
}
std::uint64_t FnvDouble(std::uint64_t h, double v) { return Fnv(h, &v, sizeof v); }

// ---- log-linear histogram: 512 bins per octave, integer counts (merging is exact) ----

constexpr int kMantissaBits = 9;

class LogHistogram {
 public:
  void Add(double v) {
    if (v == 0.0) {
      ++zero_;
      return;
    }
    Side& side = v > 0 ? positive_ : negative_;
    const long index = BinIndex(std::abs(v));
    side.Add(index, 1);
  }
  void Merge(const LogHistogram& other) {
    zero_ += other.zero_;
    positive_.Merge(other.positive_);
    negative_.Merge(other.negative_);
  }
  std::uint64_t count() const { return zero_ + positive_.Total() + negative_.Total(); }
  // Value of rank r (0-based) in ascending order, at its bin's middle.
  double ValueAt(std::uint64_t r) const {
    const std::uint64_t n_negative = negative_.Total();
    if (r < n_negative) {
      // Negative values ascending: largest magnitudes first.
      std::uint64_t left = r;
      for (long k = static_cast<long>(negative_.counts.size()) - 1; k >= 0; --k) {
        const std::uint64_t c = negative_.counts[static_cast<size_t>(k)];
        if (left < c) return -BinMiddle(negative_.offset + k);
        left -= c;
      }
    }
    r -= n_negative;
    if (r < zero_) return 0.0;
    r -= zero_;
    for (size_t k = 0; k < positive_.counts.size(); ++k) {
      const std::uint64_t c = positive_.counts[k];
      if (r < c) return BinMiddle(positive_.offset + static_cast<long>(k));
      r -= c;
    }
    return std::numeric_limits<double>::quiet_NaN();
  }
  void Write(std::string& out) const;
  const char* Read(const char* p, const char* end);
  // f(value, count) for every non-empty bin (its middle), zeros as 0.
  template <class F>
  void ForEach(F&& f) const {
    if (zero_ > 0) f(0.0, zero_);
    for (size_t k = 0; k < negative_.counts.size(); ++k)
      if (negative_.counts[k])
        f(-BinMiddle(negative_.offset + static_cast<long>(k)), negative_.counts[k]);
    for (size_t k = 0; k < positive_.counts.size(); ++k)
      if (positive_.counts[k])
        f(BinMiddle(positive_.offset + static_cast<long>(k)), positive_.counts[k]);
  }

 private:
  struct Side {
    long offset = 0;
    std::vector<std::uint64_t> counts;
    std::uint64_t Total() const {
      std::uint64_t t = 0;
      for (std::uint64_t c : counts) t += c;
      return t;
    }
    void Add(long index, std::uint64_t n) {
      if (counts.empty()) {
        offset = index;
        counts.assign(1, 0);
      }
      if (index < offset) {
        counts.insert(counts.begin(), static_cast<size_t>(offset - index), 0);
        offset = index;
      } else if (index >= offset + static_cast<long>(counts.size())) {
        counts.resize(static_cast<size_t>(index - offset + 1), 0);
      }
      counts[static_cast<size_t>(index - offset)] += n;
    }
    void Merge(const Side& other) {
      for (size_t k = 0; k < other.counts.size(); ++k) {
        if (other.counts[k] != 0) Add(other.offset + static_cast<long>(k), other.counts[k]);
      }
    }
  };
  static long BinIndex(double magnitude) {
    std::uint64_t bits;
    std::memcpy(&bits, &magnitude, sizeof bits);
    return static_cast<long>(bits >> (52 - kMantissaBits));  // exponent and top mantissa bits
  }
  static double BinMiddle(long index) {
    const std::uint64_t low = static_cast<std::uint64_t>(index) << (52 - kMantissaBits);
    const std::uint64_t high = static_cast<std::uint64_t>(index + 1) << (52 - kMantissaBits);
    double a, b;
    std::memcpy(&a, &low, sizeof a);
    std::memcpy(&b, &high, sizeof b);
    return 0.5 * (a + b);
  }
  std::uint64_t zero_ = 0;
  Side positive_, negative_;
};

template <class T>
void Put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
const char* Get(const char* p, const char* end, T* v) {
  if (p == nullptr || end - p < static_cast<std::ptrdiff_t>(sizeof(T)))
    throw Error("uncertainty partial: truncated bytes");
  std::memcpy(v, p, sizeof(T));
  return p + sizeof(T);
}

void LogHistogram::Write(std::string& out) const {
  Put(out, zero_);
  for (const Side* s : {&positive_, &negative_}) {
    Put(out, s->offset);
    Put(out, static_cast<std::uint64_t>(s->counts.size()));
    out.append(reinterpret_cast<const char*>(s->counts.data()),
               s->counts.size() * sizeof(std::uint64_t));
  }
}

const char* LogHistogram::Read(const char* p, const char* end) {
  p = Get(p, end, &zero_);
  for (Side* s : {&positive_, &negative_}) {
    std::uint64_t n = 0;
    p = Get(p, end, &s->offset);
    p = Get(p, end, &n);
    if (static_cast<std::uint64_t>(end - p) < n * sizeof(std::uint64_t))
      throw Error("uncertainty partial: truncated histogram");
    s->counts.resize(static_cast<size_t>(n));
    if (n > 0) std::memcpy(s->counts.data(), p, static_cast<size_t>(n) * sizeof(std::uint64_t));
    p += n * sizeof(std::uint64_t);
  }
  return p;
}

// A vector whose resize leaves new doubles uninitialised (they are written right after): the
// percentile values of a study are hundreds of megabytes at the budget's limit.
template <class T>
struct UncDefaultInit : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UncDefaultInit<U>;
  };
  UncDefaultInit() = default;
  template <class U>
  UncDefaultInit(const UncDefaultInit<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
using ValueVector = std::vector<double, UncDefaultInit<double>>;

// ---- per-block sums ----
// Layout of one (block, posture) record, all doubles, added in block order:
//   [0] rows, [1] valid, [2] no equilibrium, [3] invalid, [4] small-motion failures,
//   then per quantity: n, sum(y - c), sum((y - c)^2), Sobol rows n_s,
//   then per group and quantity: sum f_B (f_ABi - f_A), sum (f_A - f_ABi)^2.
constexpr int kCounts = 5;
constexpr int kPerQuantity = 4;

}  // namespace

struct UncertaintyStudy::Impl {
  explicit Impl(const Model& m) : model(m), nominal_set(m.model_stiffness()) {}
  Model model;
  StiffnessSet nominal_set;  // the model's own (Model::model_stiffness)
  // Per group: true when its dimensions only set values (stiffness, reading terms), so that a
  // row A_B^g is row A with those values replaced (angles add and factors multiply: rebuilt).
  std::vector<char> group_sets_only;
  int muscle = 0;
  std::string muscle_name;
  Eigen::MatrixXd postures;
  UncertaintyOptions options;
  std::vector<std::string> groups;
  std::vector<Dimension> dims;
  int fit_group = -1;
  Eigen::MatrixXd fit_cholesky;  // over the fit's parameters
  Eigen::VectorXd fit_mean;
  std::vector<int> fit_dims;  // dims of the fit, in parameter order
  // Rows are evaluated one by one (ComputeKinematics + SolveStatics), not as stiffness sets of
  // the batch: some dimension changes the posture or the muscle's path points, or the
  // activation of a muscle with a force model (whose F(L_MT, a) is not proportional to a).
  bool kinematic = false;
  bool has_points = false;  // some dimension moves a path point (RowInputs::points)
  int path_points = 0;      // the study's muscle's path points
  // The muscle has a force model (thelen2003, millard2012): the engine evaluates F(L_MT, a) at
  // each row's activation (EngineActivation) and W is scaled by the force factors only
  // (WScale); with the constant model W is computed at activation 1 and scaled by both.
  bool force_model = false;
  bool has_post = false;  // some dimension acts on the reading
  double nominal_activation = 1.0;
  Vector6d reach_scale = Vector6d::Ones();  // D = diag(1, 1, 1, L, L, L)
  long samples = 0;
  bool exact = true;
  std::uint64_t fingerprint = 0;
  std::vector<std::string> notes;
  // Per posture, from its nominal kinematics: R_W_T, the nominal quantities, the
  // reconstruction of dtheta from W (batch path), J and tau at activation 1.
  struct PostureData {
    Eigen::Matrix3d R_W_T = Eigen::Matrix3d::Identity();
    std::array<double, kQ> nominal{};
    StaticsStatus nominal_status = StaticsStatus::kInvalidInput;
    Eigen::Vector3d force_direction = Eigen::Vector3d::Zero();  // unit, or 0: no angle
    Matrix6Xd J;
    Eigen::VectorXd tau;
    Eigen::MatrixXd dtheta_from;  // m x (rows + stiff columns)
  };
  std::vector<PostureData> posture_data;
  std::vector<int> restrained_rows;  // s_t > 0 in every sample
  std::vector<int> stiff_columns;    // s_p > 0 in every sample, not locked
  std::vector<char> locked;
  std::vector<char> revolute;
  double leg_length = 0.0;

  int G() const { return static_cast<int>(groups.size()); }
  // The activation the engine is called with for a row of activation a (see force_model), and
  // the factor on its W.
  double EngineActivation(double a) const { return force_model ? a : 1.0; }
  double WScale(double factor, double a) const { return force_model ? factor : factor * a; }
  int Rows() const { return options.sobol ? G() + 2 : 1; }
  int RecordSize() const { return kCounts + kQ * kPerQuantity + 2 * G() * kQ; }

  // Sample j's uniforms: word w of its stream is word w % 4 of Philox call (seed; j, 0, w / 4).
  // With the Sobol design (uB not null) dimension k of matrix A is word 2 k and of matrix B word
  // 2 k + 1; without it dimension k is word k. No word of a call is thrown away, and a
  // dimension's uniforms do not depend on how many dimensions follow it.
  void Draw(long j, double* uA, double* uB) const {
    const int D = static_cast<int>(dims.size());
    const int words = uB ? 2 * D : D;
    for (int w = 0; w < words; w += 4) {
      const std::array<double, 4> r = PhiloxUniforms(options.seed, static_cast<std::uint64_t>(j), 0,
                                                     static_cast<std::uint64_t>(w / 4));
      for (int l = 0; l < 4 && w + l < words; ++l) {
        const int i = w + l;
        if (!uB) {
          uA[i] = r[static_cast<size_t>(l)];
        } else {
          (i % 2 == 0 ? uA : uB)[i / 2] = r[static_cast<size_t>(l)];
        }
      }
    }
  }

  // The value of every dimension for the uniforms u (D of them), the fit's transform applied.
  void Values(const double* u, std::vector<double>& values) const;
  // A row's inputs: the dimensions of group `swap` from values_b, the others from values_a.
  void Assemble(const double* values_a, const double* values_b, int swap, RowInputs& row) const;
  void Apply(const Dimension& d, double value, RowInputs& row) const;
  // The stiffness targets of Apply (others: nothing).
  void ApplyToSet(const Dimension& d, double value, StiffnessSet& set) const;
  void Nominal(RowInputs& row) const;
  // `to` = `from`, the parts the study uses only.
  void CopyRow(const RowInputs& from, RowInputs& to) const;
  // The reading's quantities from W (transducer axes, activation 1) and the row's inputs, in
  // lane order (kLanes entries, kLaneOf). world: also the world-axes components (else 0: A_B^i
  // rows need only the Sobol quantities).
  // Returns kRowFinite / kAngleFinite flags (below).
  int Quantities(const PostureData& pd, const Vector6d& W1, const RowInputs& row, double* y,
                 bool world = true) const;
  // The same from the reading W itself.
  static int ReadingQuantities(const PostureData& pd, const Vector6d& W, double* y, bool world);
  bool SmallMotionFails(const Matrix6Xd& J, const Eigen::VectorXd& dtheta) const;
};

void UncertaintyStudy::Impl::ApplyToSet(const Dimension& d, double v, StiffnessSet& set) const {
  switch (d.target) {
    case Target::kTransducerStiffness:
      set.s_t[d.index] = d.absolute ? v : nominal_set.s_t[d.index] * v;
      break;
    case Target::kTransducerRotationFactor:
      for (int r = 3; r < 6; ++r) set.s_t[r] = nominal_set.s_t[r] * v;
      break;
    case Target::kJointStiffness:
      for (int c : d.columns) set.s_p[c] = d.absolute ? v : nominal_set.s_p[c] * v;
      break;
    default: break;
  }
}

void UncertaintyStudy::Impl::Apply(const Dimension& d, double v, RowInputs& row) const {
  switch (d.target) {
    case Target::kTransducerStiffness:
    case Target::kTransducerRotationFactor:
    case Target::kJointStiffness: ApplyToSet(d, v, row.set); break;
    case Target::kAngle: row.dq[d.index] += v; break;
    case Target::kForceFactor: row.factor *= v; break;
    case Target::kActivation: row.activation = v; break;
    case Target::kMisalignment: row.rotation[d.index] = v; break;
    case Target::kGain: row.gain[d.index] = v; break;
    case Target::kCrosstalk: row.crosstalk(d.index / 6, d.index % 6) = v; break;
    case Target::kCrosstalkSymmetric:
      row.crosstalk(d.index / 6, d.index % 6) = v;
      row.crosstalk(d.index % 6, d.index / 6) = v;
      break;
    case Target::kSensorOrigin: row.origin[d.index] = v; break;
    case Target::kSensorOffset: row.offset[d.index] = v; break;
    case Target::kPointOffset: row.points(d.index % 3, d.index / 3) += v; break;
    case Target::kNone: break;
  }
}

void UncertaintyStudy::Impl::Nominal(RowInputs& row) const {
  row.set = nominal_set;
  if (kinematic || row.dq.size() == 0) row.dq.setZero(model.dof_count());
  row.factor = 1.0;
  row.activation = nominal_activation;
  if (has_points) row.points.setZero(3, path_points);
  if (!has_post) return;  // the reading terms are never read
  row.rotation.setZero();
  row.gain.setOnes();
  row.crosstalk.setZero();
  row.origin.setZero();
  row.offset.setZero();
}

void UncertaintyStudy::Impl::CopyRow(const RowInputs& from, RowInputs& to) const {
  to.set.s_t = from.set.s_t;
  to.set.s_p = from.set.s_p;
  if (kinematic) to.dq = from.dq;
  to.factor = from.factor;
  to.activation = from.activation;
  if (has_points) to.points = from.points;
  if (!has_post) return;
  to.rotation = from.rotation;
  to.gain = from.gain;
  to.crosstalk = from.crosstalk;
  to.origin = from.origin;
  to.offset = from.offset;
}

void UncertaintyStudy::Impl::Values(const double* u, std::vector<double>& values) const {
  const int D = static_cast<int>(dims.size());
  values.resize(static_cast<size_t>(D + fit_mean.size()));  // the tail: the fit's x
  for (int k = 0; k < D; ++k) {
    const Dimension& d = dims[static_cast<size_t>(k)];
    // A fit dimension holds z first, transformed below.
    values[static_cast<size_t>(k)] =
        d.fit_index >= 0 ? NormalQuantile(u[k]) : IndependentValue(d, u[k]);
  }
  if (fit_group >= 0) {
    // x = mean + L z over the fit's parameters (one group: all swapped together).
    const Eigen::Index n = fit_mean.size();
    for (Eigen::Index i = 0; i < n; ++i) {
      double x = fit_mean[i];
      for (Eigen::Index l = 0; l <= i; ++l)
        x += fit_cholesky(i, l) * values[static_cast<size_t>(fit_dims[static_cast<size_t>(l)])];
      const Dimension& d = dims[static_cast<size_t>(fit_dims[static_cast<size_t>(i)])];
      values[static_cast<size_t>(D + i)] =
          d.log10_value ? std::pow(10.0, x) * d.scale : x * d.scale;
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      values[static_cast<size_t>(fit_dims[static_cast<size_t>(i)])] =
          values[static_cast<size_t>(D + i)];
    }
  }
}

void UncertaintyStudy::Impl::Assemble(const double* values_a, const double* values_b, int swap,
                                      RowInputs& row) const {
  Nominal(row);
  const int D = static_cast<int>(dims.size());
  for (int k = 0; k < D; ++k) {
    const Dimension& d = dims[static_cast<size_t>(k)];
    Apply(d, d.group == swap ? values_b[k] : values_a[k], row);
  }
}

int UncertaintyStudy::Impl::Quantities(const PostureData& pd, const Vector6d& W1,
                                       const RowInputs& row, double* y, bool world) const {
  Vector6d W = WScale(row.factor, row.activation) * W1;
  if (has_post) {
    // Misalignment: readings in axes turned by R = exp([r]x): R^T W.
    const double angle = row.rotation.norm();
    if (angle > 0) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, row.rotation / angle).toRotationMatrix();
      W.head<3>() = R.transpose() * W.head<3>().eval();
      W.tail<3>() = R.transpose() * W.tail<3>().eval();
    }
    // Moment about the true origin d: m - d x f.
    W.tail<3>() -= row.origin.cross(W.head<3>());
    // Calibration: (I + E) W, E = D Ê D^-1 off the diagonal, gain - 1 on it.
    Vector6d reading;
    for (int i = 0; i < 6; ++i) {
      double r = row.gain[i] * W[i];
      for (int k = 0; k < 6; ++k) {
        if (k != i) r += reach_scale[i] / reach_scale[k] * row.crosstalk(i, k) * W[k];
      }
      reading[i] = r;
    }
    W = reading + row.offset;
  }
  return ReadingQuantities(pd, W, y, world);
}

int UncertaintyStudy::Impl::ReadingQuantities(const PostureData& pd, const Vector6d& W, double* y,
                                              bool world) {
  // y in lane order (kLaneOf): the reading, |f|, |m|, the angle, the world axes, a pad; the
  // arithmetic of the batch rows' RowQuantityLanes.
  ReadingLaneQuantities(W.data(), pd.R_W_T.data(), pd.force_direction.data(),
                        !pd.force_direction.isZero(), y);
  bool finite = true;
  if (world) {
    for (int i = 9; i < 15; ++i) finite = finite && std::isfinite(y[i]);
  } else {
    for (int i = 9; i < 15; ++i) y[i] = 0.0;  // not a Sobol quantity (kSobolQuantity)
  }
  // A finite |f| (the square root of the sum of squares) has finite components; so has |m|.
  finite = finite && std::isfinite(y[6]) && std::isfinite(y[7]);
  return (finite ? kRowFinite : 0) | (std::isfinite(y[8]) ? kAngleFinite : 0);
}

bool UncertaintyStudy::Impl::SmallMotionFails(const Matrix6Xd& J,
                                              const Eigen::VectorXd& dtheta) const {
  // docs/model.md "Validity of the linear model", as SolveStatics (statics.cpp) applies it
  // (plain loops: this runs for every row of A and B).
  const Eigen::Index m = dtheta.size();
  double v[3] = {0.0, 0.0, 0.0};
  for (Eigen::Index c = 0; c < m; ++c) {
    const double* Jc = J.col(c).data();
    for (int i = 0; i < 3; ++i) v[i] += Jc[i] * dtheta[c];
  }
  const double translation = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  const double limit = options.statics.max_endpoint_fraction * leg_length;
  if (leg_length > 0 && translation > limit) return true;
  for (Eigen::Index c = 0; c < m; ++c) {
    const double a = std::abs(dtheta[c]);
    if (revolute[static_cast<size_t>(c)]) {
      if (a > options.statics.max_joint_rotation) return true;
    } else if (leg_length > 0 && a > limit) {
      return true;
    }
  }
  return false;
}

namespace {

// Resolve one user input into dimensions. `group` is its Sobol group.
void ResolveInput(const UncertainInput& in, int group, const Model& model, int muscle,
                  double activation, std::vector<Dimension>& dims) {
  const std::string& name = in.name;
  const std::string what = "uncertain input '" + name + "'";
  auto sd_at = [&](size_t k) { return in.sd.size() == 1 ? in.sd[0] : in.sd[k]; };
  auto check_sd = [&](size_t count) {
    if (in.distribution == InputDistribution::kUniform ||
        in.distribution == InputDistribution::kLogUniform) {
      if (!in.sd.empty())
        throw Error(what + ": a " + DistributionName(in.distribution) +
                    " input takes lower and upper, not sd");
      if (!std::isfinite(in.lower) || !std::isfinite(in.upper) || !(in.lower < in.upper)) {
        throw Error(what + ": empty support [" + util::FormatNumber(in.lower) + ", " +
                    util::FormatNumber(in.upper) + "]: needs lower < upper");
      }
      if (in.distribution == InputDistribution::kLogUniform && !(in.lower > 0)) {
        throw Error(what + ": empty support for loguniform: lower " + util::FormatNumber(in.lower) +
                    " must be > 0");
      }
      return;
    }
    if (in.sd.empty()) throw Error(what + ": needs sd");
    if (in.sd.size() != 1 && in.sd.size() != count) {
      throw Error(what + ": sd has " + std::to_string(in.sd.size()) + " values; give 1" +
                  (count > 1 ? " or " + std::to_string(count) : std::string()));
    }
    for (double s : in.sd) {
      if (!std::isfinite(s) || s < 0)
        throw Error(what + ": sd " + util::FormatNumber(s) + " must be finite and >= 0");
    }
  };
  auto allow = [&](std::initializer_list<InputDistribution> allowed) {
    for (InputDistribution d : allowed)
      if (d == in.distribution) return;
    std::string list;
    for (InputDistribution d : allowed)
      list += std::string(list.empty() ? "" : ", ") + DistributionName(d);
    throw Error(what + ": distribution " + DistributionName(in.distribution) +
                " is not available for it (" + list + ")");
  };
  auto base = [&](Target target) {
    Dimension d;
    d.group = group;
    d.distribution = in.distribution;
    d.target = target;
    return d;
  };
  // Stiffness: lognormal factor (median 1) or loguniform absolute values.
  auto stiffness = [&](Target target, int index, std::vector<int> columns, double nominal) {
    allow({InputDistribution::kLogNormal, InputDistribution::kLogUniform});
    check_sd(1);
    Dimension d = base(target);
    d.index = index;
    d.columns = std::move(columns);
    if (in.distribution == InputDistribution::kLogNormal) {
      if (!(nominal > 0)) {
        throw Error(what + ": the model's value is 0 (released or without stiffness): a " +
                    "lognormal factor on it is empty; give a loguniform lower/upper instead");
      }
      d.a = 1.0;
      d.b = in.sd[0];
    } else {
      d.absolute = true;
      d.a = std::log(in.lower);
      d.b = std::log(in.upper);
    }
    dims.push_back(d);
  };
  // A factor with mean / median 1.
  auto factor = [&](Target target, int index) {
    allow({InputDistribution::kNormal, InputDistribution::kLogNormal, InputDistribution::kUniform});
    check_sd(1);
    Dimension d = base(target);
    d.index = index;
    if (in.distribution == InputDistribution::kUniform) {
      d.a = in.lower;
      d.b = in.upper;
    } else {
      d.a = 1.0;
      d.b = in.sd[0];
    }
    dims.push_back(d);
  };
  // Normal offsets with mean 0 (or uniform offsets), per axis, times `unit`.
  auto offsets = [&](Target target, int first_index, int count, double unit) {
    allow({InputDistribution::kNormal, InputDistribution::kUniform});
    check_sd(static_cast<size_t>(count));
    for (int k = 0; k < count; ++k) {
      Dimension d = base(target);
      d.index = first_index + k;
      if (in.distribution == InputDistribution::kUniform) {
        d.a = in.lower * unit;
        d.b = in.upper * unit;
      } else {
        d.a = 0.0;
        d.b = sd_at(static_cast<size_t>(k)) * unit;
      }
      dims.push_back(d);
    }
  };

  const size_t colon = name.find(':');
  const std::string kind = name.substr(0, colon);
  const std::string arg = colon == std::string::npos ? "" : name.substr(colon + 1);
  const std::vector<std::string> kinds = {"transducer_stiffness",
                                          "base_stiffness",
                                          "joint_stiffness",
                                          "angle",
                                          "max_force",
                                          "activation",
                                          "misalignment",
                                          "gain",
                                          "crosstalk",
                                          "point"};
  if (kind == "transducer_stiffness") {
    int dof = -1;
    for (int k = 0; k < 6; ++k)
      if (arg == kDofNames[k]) dof = k;
    if (dof < 0) {
      throw Error(what + ": unknown transducer dof '" + arg + "'" +
                  DidYouMean(arg, {"x", "y", "z", "rx", "ry", "rz"}) + " (x y z rx ry rz)");
    }
    if (model.model_stiffness().s_t[dof] == 0) {
      // A released dof has no stiffness to be uncertain about: sampling one would restrain it.
      throw Error(what + ": transducer dof '" + arg +
                  "' is released (stiffness 0): it holds nothing, so its stiffness is not an "
                  "input (drop it, or restrain it with --release)");
    }
    stiffness(Target::kTransducerStiffness, dof, {}, model.model_stiffness().s_t[dof]);
  } else if (kind == "base_stiffness") {
    std::vector<int> columns;
    for (int c = 0; c < model.dof_count(); ++c)
      if (model.coordinate(c).role == JointRole::kBase) columns.push_back(c);
    if (columns.empty()) {
      throw Error(what + ": model '" + model.name() +
                  "' has no base dofs (give --base-stiffness, or a URDF with base joints)");
    }
    double nominal = model.model_stiffness().s_p[columns[0]];
    for (int c : columns) nominal = std::min(nominal, model.model_stiffness().s_p[c]);
    stiffness(Target::kJointStiffness, 0, columns, nominal);
  } else if (kind == "joint_stiffness") {
    const int c = model.JointIndex(arg);  // throws with the closest name
    if (model.coordinate(c).locked) {
      throw Error(what + ": coordinate '" + arg +
                  "' is locked (held rigid): its stiffness changes nothing (unlock it with "
                  "--lock, or drop this input)");
    }
    stiffness(Target::kJointStiffness, 0, {c}, model.model_stiffness().s_p[c]);
  } else if (kind == "angle") {
    const int c = model.JointIndex(arg);
    const bool prismatic = model.joint(c).type == JointType::kPrismatic;
    offsets(Target::kAngle, c, 1, prismatic ? 1e-3 : kPi / 180.0);
  } else if (kind == "max_force") {
    if (!arg.empty() && arg != model.muscle(muscle).name) {
      model.MuscleIndex(arg);  // unknown: throws with the list
      throw Error(what + ": the study is of muscle '" + model.muscle(muscle).name +
                  "'; max_force of '" + arg + "' does not change its wrench");
    }
    factor(Target::kForceFactor, 0);
  } else if (kind == "activation") {
    allow({InputDistribution::kNormal, InputDistribution::kUniform});
    check_sd(1);
    Dimension d = base(Target::kActivation);
    if (in.distribution == InputDistribution::kUniform) {
      d.a = in.lower;
      d.b = in.upper;
    } else {
      d.a = activation;
      d.b = in.sd[0];
    }
    dims.push_back(d);
  } else if (kind == "misalignment") {
    if (!arg.empty()) throw Error(what + ": misalignment takes no ':' argument (sd per axis)");
    offsets(Target::kMisalignment, 0, 3, kPi / 180.0);
  } else if (kind == "gain") {
    const int axis = AxisIndexOf(arg);
    if (axis < 0) {
      throw Error(what + ": unknown axis '" + arg + "'" +
                  DidYouMean(arg, {"fx", "fy", "fz", "mx", "my", "mz"}) + " (fx fy fz mx my mz)");
    }
    factor(Target::kGain, axis);
  } else if (kind == "crosstalk") {
    if (arg.empty()) {
      allow({InputDistribution::kNormal});
      check_sd(1);
      for (int i = 0; i < 6; ++i) {
        for (int k = 0; k < 6; ++k) {
          if (i == k) continue;
          Dimension d = base(Target::kCrosstalk);
          d.index = i * 6 + k;
          d.b = in.sd[0];
          dims.push_back(d);
        }
      }
    } else {
      const size_t bar = arg.find('_');
      const int i = AxisIndexOf(arg.substr(0, bar));
      const int k = bar == std::string::npos ? -1 : AxisIndexOf(arg.substr(bar + 1));
      if (i < 0 || k < 0 || i == k) {
        throw Error(what + ": '" + arg +
                    "' is not a term <reading>_<source> of two different axes (e.g. mx_fy)");
      }
      offsets(Target::kCrosstalk, i * 6 + k, 1, 1.0);
    }
  } else if (kind == "point") {
    // point:<muscle>:<index> (three axes, one group) or point:<muscle>:<index>:<axis>.
    std::vector<std::string> parts;
    for (size_t start = 0;;) {
      const size_t next = arg.find(':', start);
      parts.push_back(arg.substr(start, next == std::string::npos ? next : next - start));
      if (next == std::string::npos) break;
      start = next + 1;
    }
    if (arg.empty() || parts.size() < 2 || parts.size() > 3) {
      throw Error(what + ": name a path point as point:<muscle>:<index> (all three axes) or " +
                  "point:<muscle>:<index>:<axis> (x, y or z), e.g. point:" +
                  model.muscle(muscle).name + ":0 (the origin)");
    }
    const std::string& muscle_name = parts[0];
    std::vector<std::string> muscles;
    for (int i = 0; i < model.muscle_count(); ++i) muscles.push_back(model.muscle(i).name);
    if (std::find(muscles.begin(), muscles.end(), muscle_name) == muscles.end()) {
      throw Error(what + ": unknown muscle '" + muscle_name + "'" +
                  DidYouMean(muscle_name, muscles) + " in model '" + model.name() + "'");
    }
    if (muscle_name != model.muscle(muscle).name) {
      throw Error(what + ": the study is of muscle '" + model.muscle(muscle).name +
                  "'; a path point of '" + muscle_name + "' does not change its wrench");
    }
    const int n_points = static_cast<int>(model.muscle(muscle).path.size());
    const std::string& index_text = parts[1];
    int point = -1;
    const bool number = !index_text.empty() && index_text.size() <= 6 &&
                        index_text.find_first_not_of("0123456789") == std::string::npos;
    if (number) point = std::stoi(index_text);
    if (point < 0 || point >= n_points) {
      std::vector<std::string> indices;
      for (int i = 0; i < n_points; ++i) indices.push_back(std::to_string(i));
      // The nearest index for a number, else the closest spelling.
      const std::string hint = point >= n_points
                                   ? " (did you mean '" + std::to_string(n_points - 1) + "'?)"
                                   : DidYouMean(index_text, indices);
      throw Error(what + ": unknown path point '" + index_text + "'" + hint + ": muscle '" +
                  muscle_name + "' has " + std::to_string(n_points) +
                  " path points, 0 (origin) to " + std::to_string(n_points - 1) + " (insertion)");
    }
    int axis = -1;
    if (parts.size() == 3) {
      const std::vector<std::string> axes = {"x", "y", "z"};
      for (int k = 0; k < 3; ++k)
        if (parts[2] == axes[static_cast<size_t>(k)]) axis = k;
      if (axis < 0) {
        throw Error(what + ": unknown axis '" + parts[2] + "'" + DidYouMean(parts[2], axes) +
                    " (x y z of the point's link frame)");
      }
    }
    // Normal (or uniform) offsets in mm, mean 0, in the point's link frame.
    if (axis >= 0) {
      offsets(Target::kPointOffset, point * 3 + axis, 1, 1e-3);
    } else {
      offsets(Target::kPointOffset, point * 3, 3, 1e-3);
    }
  } else {
    throw Error(
        "unknown uncertain input '" + name + "'" + DidYouMean(kind, kinds) +
        " (inputs: transducer_stiffness:<dof>, base_stiffness, joint_stiffness:<coordinate>, "
        "angle:<coordinate>, max_force, activation, misalignment, gain:<axis>, crosstalk, "
        "point:<muscle>:<index>[:<axis>])");
  }
}

// The fit's parameters as dimensions of one group.
void ResolveFit(const FitUncertainty& fit, int group, const Model& model, int muscle,
                std::vector<Dimension>& dims, std::vector<int>& fit_dims,
                std::vector<std::string>& notes) {
  for (size_t k = 0; k < fit.names.size(); ++k) {
    const std::string& full = fit.names[k];
    const size_t dot = full.rfind('.');
    const std::string effect = full.substr(0, dot), parameter = full.substr(dot + 1);
    Dimension d;
    d.group = group;
    d.fit_index = static_cast<int>(k);
    d.log10_value = fit.log10[k];
    d.a = fit.log10[k] ? std::pow(10.0, fit.mean[static_cast<Eigen::Index>(k)])
                       : fit.mean[static_cast<Eigen::Index>(k)];
    const std::string what = fit.source + ": " + full;
    if (effect == "base_isotropic" || effect == "base_per_axis") {
      d.target = Target::kJointStiffness;
      d.absolute = true;
      for (int c = 0; c < model.dof_count(); ++c) {
        if (model.coordinate(c).role != JointRole::kBase) continue;
        const std::string& n = model.coordinate(c).name;
        if (effect == "base_isotropic" || ("k_" + n) == parameter ||
            ("k_base_" + n.substr(n.size() - 1)) == parameter)
          d.columns.push_back(c);
      }
      if (d.columns.empty()) {
        throw Error(what + ": the model has no base dofs for it; give --base-stiffness " +
                    util::FormatNumber(d.a) + " (the fitted value) to add them");
      }
    } else if (effect.rfind("transducer_soft:", 0) == 0) {
      d.target = Target::kTransducerStiffness;
      d.absolute = true;
      d.index = -1;
      for (int r = 0; r < 6; ++r)
        if (effect.substr(16) == kDofNames[r]) d.index = r;
      if (d.index < 0) throw Error(what + ": unknown dof");
    } else if (effect == "transducer_anisotropy") {
      d.target = Target::kTransducerRotationFactor;
    } else if (effect.rfind("force_scale:", 0) == 0) {
      if (effect.substr(12) != model.muscle(muscle).name) {
        notes.push_back(full + " is of another muscle: it does not change this study's wrench");
      }
      d.target =
          effect.substr(12) == model.muscle(muscle).name ? Target::kForceFactor : Target::kNone;
    } else if (effect.rfind("gain:", 0) == 0) {
      d.target = Target::kGain;
      d.index = AxisIndexOf(effect.substr(5));
      if (d.index < 0) throw Error(what + ": unknown axis");
    } else if (effect == "crosstalk") {
      const size_t bar = parameter.find('_');
      const int i = AxisIndexOf(parameter.substr(0, bar));
      const int s = bar == std::string::npos ? -1 : AxisIndexOf(parameter.substr(bar + 1));
      if (i < 0 || s < 0) throw Error(what + ": not a crosstalk term");
      // Before issue 29 the fit's crosstalk was symmetric (15 terms a_b, a before b); from
      // issue 29 on it is <reading>_<source>, 30 terms. A fit that names some term with its
      // reading after its source, or both orders, is of the second kind.
      bool ordered = false;
      for (const std::string& other : fit.names) {
        if (other.rfind("crosstalk.", 0) != 0) continue;
        const std::string t = other.substr(10);
        const size_t b2 = t.find('_');
        if (AxisIndexOf(t.substr(0, b2)) > AxisIndexOf(t.substr(b2 + 1))) ordered = true;
      }
      d.target = ordered ? Target::kCrosstalk : Target::kCrosstalkSymmetric;
      d.index = i * 6 + s;
    } else if (effect == "misalignment") {
      d.target = Target::kMisalignment;
      d.index = parameter == "rx" ? 0 : parameter == "ry" ? 1 : 2;
      d.scale = kPi / 180.0;
    } else if (effect == "sensor_origin") {
      d.target = Target::kSensorOrigin;
      d.index = parameter == "dx" ? 0 : parameter == "dy" ? 1 : 2;
      d.scale = 1e-3;
    } else if (effect == "sensor_offset") {
      d.target = Target::kSensorOffset;
      d.index = std::max(0, AxisIndexOf(parameter));
    } else if (effect.rfind("attachment:", 0) == 0) {
      // attachment:<muscle>:<i>, dx dy dz (mm, the point's link frame): the identification
      // moves MuscleSpec::path[i].position by them, as SetPathPointOffsets does.
      const std::string rest = effect.substr(11);
      const size_t colon = rest.rfind(':');
      const std::string name = rest.substr(0, colon);
      const std::string index = colon == std::string::npos ? "" : rest.substr(colon + 1);
      const int axis = parameter == "dx" ? 0 : parameter == "dy" ? 1 : parameter == "dz" ? 2 : -1;
      if (name != model.muscle(muscle).name) {
        if (parameter == "dx")
          notes.push_back(effect + " is of another muscle: it does not change this study's wrench");
        d.target = Target::kNone;
      } else {
        const int n_points = static_cast<int>(model.muscle(muscle).path.size());
        const bool number = !index.empty() && index.size() <= 6 &&
                            index.find_first_not_of("0123456789") == std::string::npos;
        const int point = number ? std::stoi(index) : -1;
        if (point < 0 || point >= n_points || axis < 0) {
          throw Error(what + ": muscle '" + name + "' has no path point '" + index +
                      "' with a parameter '" + parameter + "' (" + std::to_string(n_points) +
                      " path points; dx, dy, dz)");
        }
        d.target = Target::kPointOffset;
        d.index = point * 3 + axis;
        d.scale = 1e-3;
      }
    } else if (effect.rfind("joint_offset:", 0) == 0) {
      d.target = Target::kAngle;
      d.index = model.JointIndex(effect.substr(13));
      d.scale = model.joint(d.index).type == JointType::kPrismatic ? 1e-3 : kPi / 180.0;
    } else {
      throw Error(what + ": this effect cannot be sampled");
    }
    fit_dims.push_back(static_cast<int>(dims.size()));
    dims.push_back(d);
  }
}

}  // namespace

UncertaintyStudy::UncertaintyStudy(const Model& model, const std::string& muscle,
                                   const Eigen::MatrixXd& postures, const UncertaintySpec& spec,
                                   const UncertaintyOptions& options)
    : impl_(std::make_shared<Impl>(model)) {
  Impl& s = *impl_;
  s.muscle = model.MuscleIndex(muscle);
  s.muscle_name = muscle;
  s.options = options;
  s.options.progress = nullptr;
  if (options.samples <= 0)
    throw Error("uncertainty: samples " + std::to_string(options.samples) + " must be > 0");
  if (options.threads < 1)
    throw Error("uncertainty: threads " + std::to_string(options.threads) + " must be >= 1");
  if (!std::isfinite(options.activation)) throw Error("uncertainty: activation must be finite");
  // The constant model's W is linear in activation and max_force: W1 at activation 1 times
  // both. A force model's F(L_MT, a) = max_force f(L_MT, a) is linear in max_force (every term
  // of the fiber-tendon equilibrium scales with it: the force factors still multiply W), but
  // not in a (passive force, minimum activation, the compliant tendon's equilibrium): the
  // engine evaluates it at each row's activation (docs/uncertainty.md "Force models").
  s.force_model = model.muscle(s.muscle).force.model != ForceModelType::kConstant;
  if (s.force_model && !(options.activation >= 0.0 && options.activation <= 1.0)) {
    throw Error("uncertainty: activation " + util::FormatNumber(options.activation) +
                " of muscle '" + muscle + "' (force model " +
                ForceModelName(model.muscle(s.muscle).force.model) + ") is outside [0, 1]");
  }
  s.path_points = static_cast<int>(model.muscle(s.muscle).path.size());
  if (postures.rows() != model.dof_count() || postures.cols() < 1) {
    throw Error("uncertainty: postures must be " + std::to_string(model.dof_count()) +
                " x P (P >= 1), got " + std::to_string(postures.rows()) + " x " +
                std::to_string(postures.cols()));
  }
  if (!postures.allFinite()) throw Error("uncertainty: a posture has a non-finite entry");
  s.postures = postures;
  s.samples = options.samples;
  s.nominal_activation = options.activation;
  const double L = model.chain_length();
  s.reach_scale << 1, 1, 1, L, L, L;
  s.leg_length = options.statics.leg_length > 0 ? options.statics.leg_length : L;

  std::vector<std::string> seen;
  for (const UncertainInput& in : spec.inputs) {
    if (std::find(seen.begin(), seen.end(), in.name) != seen.end())
      throw Error("uncertain input '" + in.name + "' is given twice");
    seen.push_back(in.name);
    const int group = static_cast<int>(s.groups.size());
    s.groups.push_back(in.name);
    ResolveInput(in, group, model, s.muscle, options.activation, s.dims);
  }
  if (spec.has_fit && spec.fit.model != model.name()) {
    throw Error(spec.fit.source + " is a fit of model '" + spec.fit.model + "', not of '" +
                model.name() + "': its parameters do not apply to this model");
  }
  if (spec.has_fit && !spec.fit.names.empty()) {
    s.fit_group = static_cast<int>(s.groups.size());
    s.groups.push_back("fit");
    ResolveFit(spec.fit, s.fit_group, model, s.muscle, s.dims, s.fit_dims, s.notes);
    s.fit_mean = spec.fit.mean;
    // L with L L^T = covariance, from the eigen-decomposition (a covariance that is only
    // positive semi-definite, e.g. |r| = 1, still has one): L = V sqrt(max(lambda, 0)) made
    // lower triangular by a QR of its transpose.
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(spec.fit.covariance);
    const Eigen::MatrixXd root =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(root.transpose());
    Eigen::MatrixXd R = qr.matrixQR().triangularView<Eigen::Upper>();
    s.fit_cholesky = R.transpose();
    for (const std::string& note : spec.fit.notes) s.notes.push_back(note);
  }
  if (s.groups.empty())
    throw Error("uncertainty: no uncertain input given (a spec file, options or --from-fit)");
  s.group_sets_only.assign(s.groups.size(), 1);
  for (const Dimension& d : s.dims) {
    if (d.target == Target::kAngle || d.target == Target::kForceFactor ||
        d.target == Target::kPointOffset)
      s.group_sets_only[static_cast<size_t>(d.group)] = 0;
  }
  std::vector<int> point_axis_group(static_cast<size_t>(3 * s.path_points), -1);
  for (const Dimension& d : s.dims) {
    if (d.target == Target::kAngle) s.kinematic = true;
    if (d.target == Target::kActivation && s.force_model) {
      s.kinematic = true;
      if (d.distribution == InputDistribution::kUniform && !(d.a >= 0.0 && d.b <= 1.0)) {
        throw Error("uncertain input '" + s.groups[static_cast<size_t>(d.group)] +
                    "': activation [" + util::FormatNumber(d.a) + ", " + util::FormatNumber(d.b) +
                    "] leaves [0, 1], the range of muscle '" + muscle + "''s force model " +
                    ForceModelName(model.muscle(s.muscle).force.model));
      }
    }
    if (d.target == Target::kPointOffset) {
      s.kinematic = true;
      s.has_points = true;
      int& owner = point_axis_group[static_cast<size_t>(d.index)];
      if (owner >= 0 && owner != d.group) {
        throw Error("uncertain inputs '" + s.groups[static_cast<size_t>(owner)] + "' and '" +
                    s.groups[static_cast<size_t>(d.group)] + "' both move path point " +
                    std::to_string(d.index / 3) + " of '" + muscle + "' along " +
                    std::string(1, static_cast<char>('x' + d.index % 3)) + ": give it once");
      }
      owner = d.group;
    }
    if (d.target == Target::kMisalignment || d.target == Target::kGain ||
        d.target == Target::kCrosstalk || d.target == Target::kCrosstalkSymmetric ||
        d.target == Target::kSensorOrigin || d.target == Target::kSensorOffset)
      s.has_post = true;
  }
  const int m = model.dof_count();
  // Which rows and columns carry a stiffness in every sample (the pattern of K).
  std::vector<char> row_input(6, 0), column_input(static_cast<size_t>(m), 0);
  for (const Dimension& d : s.dims) {
    if (d.target == Target::kTransducerStiffness && d.absolute)
      row_input[static_cast<size_t>(d.index)] = 1;
    if (d.target == Target::kJointStiffness && d.absolute)
      for (int c : d.columns) column_input[static_cast<size_t>(c)] = 1;
  }
  for (int r = 0; r < 6; ++r) {
    if (model.model_stiffness().s_t[r] > 0 || row_input[static_cast<size_t>(r)])
      s.restrained_rows.push_back(r);
  }
  s.locked.assign(static_cast<size_t>(m), 0);
  s.revolute.assign(static_cast<size_t>(m), 1);
  for (int c = 0; c < m; ++c) {
    s.locked[static_cast<size_t>(c)] = model.coordinate(c).locked;
    s.revolute[static_cast<size_t>(c)] = model.revolute(c);
    if (!model.coordinate(c).locked &&
        (model.model_stiffness().s_p[c] > 0 || column_input[static_cast<size_t>(c)]))
      s.stiff_columns.push_back(c);
  }

  // Percentiles: exact while the values fit the budget.
  const double values =
      2.0 * static_cast<double>(s.samples) * static_cast<double>(postures.cols()) * kQ;
  s.exact = values <= options.exact_percentile_values;

  // Per posture: nominal kinematics (R_W_T, J, tau), the nominal evaluation, the reconstruction.
  Data data(model);
  RowInputs nominal;
  s.Nominal(nominal);
  // Central values of every dimension.
  {
    for (const Dimension& d : s.dims) {
      const double v = d.fit_index >= 0 ? d.a * d.scale : CentralValue(d);
      s.Apply(d, v, nominal);
    }
  }
  for (Eigen::Index p = 0; p < postures.cols(); ++p) {
    Impl::PostureData pd;
    const Eigen::VectorXd q = postures.col(p);
    ComputeKinematics(model, data, q, s.muscle, s.EngineActivation(s.nominal_activation));
    pd.R_W_T = data.transducer_rotation();
    pd.J = data.jacobian();
    pd.tau = data.tau();
    // dtheta from W: [J_r; I_c] dtheta = [W_r / s_r; (tau - J^T W)_c / s_c] (consistent:
    // J dtheta = S_t^-1 W on the restrained rows, and equilibrium J^T W + S_p dtheta = tau).
    {
      std::vector<int> free_columns;
      for (int c = 0; c < m; ++c)
        if (!s.locked[static_cast<size_t>(c)]) free_columns.push_back(c);
      const int rows = static_cast<int>(s.restrained_rows.size() + s.stiff_columns.size());
      Eigen::MatrixXd M =
          Eigen::MatrixXd::Zero(rows, static_cast<Eigen::Index>(free_columns.size()));
      for (size_t i = 0; i < s.restrained_rows.size(); ++i) {
        for (size_t c = 0; c < free_columns.size(); ++c)
          M(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c)) =
              pd.J(s.restrained_rows[i], free_columns[c]);
      }
      for (size_t i = 0; i < s.stiff_columns.size(); ++i) {
        const auto at = std::find(free_columns.begin(), free_columns.end(), s.stiff_columns[i]);
        M(static_cast<Eigen::Index>(s.restrained_rows.size() + i), at - free_columns.begin()) = 1.0;
      }
      Eigen::MatrixXd pinv = Eigen::MatrixXd::Zero(m, rows);
      if (rows > 0 && !free_columns.empty()) {
        Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinU | Eigen::ComputeThinV);
        const Eigen::VectorXd& sv = svd.singularValues();
        const double threshold = 1e-12 * (sv.size() > 0 ? sv[0] : 0.0);
        Eigen::VectorXd inv = sv;
        for (Eigen::Index k = 0; k < sv.size(); ++k) inv[k] = sv[k] > threshold ? 1.0 / sv[k] : 0.0;
        const Eigen::MatrixXd sub = svd.matrixV() * inv.asDiagonal() * svd.matrixU().transpose();
        for (size_t c = 0; c < free_columns.size(); ++c)
          pinv.row(free_columns[c]) = sub.row(static_cast<Eigen::Index>(c));
      }
      pd.dtheta_from = pinv;
    }
    // Nominal evaluation.
    if (s.has_points) SetPathPointOffsets(model, data, s.muscle, nominal.points);
    const bool path_ok = ComputeKinematics(model, data, q + nominal.dq, s.muscle,
                                           s.EngineActivation(nominal.activation));
    ClearPathPointOffsets(data);
    SolveOptions solve;
    solve.rank_tolerance = options.statics.rank_tolerance;
    solve.excitation_tolerance = options.statics.excitation_tolerance;
    // (no path or no muscle equilibrium at the central values: no nominal wrench)
    const WrenchResult w = path_ok ? SolveStatics(model, data, nominal.set, solve) : WrenchResult{};
    pd.nominal_status = w.status;
    pd.force_direction.setZero();
    if (w.status == StaticsStatus::kOk || w.status == StaticsStatus::kSelfMotionHeld) {
      double y[kLanes];
      s.Quantities(pd, w.wrench, nominal, y);
      for (int q = 0; q < kQ; ++q) pd.nominal[static_cast<size_t>(q)] = y[kLaneOf[q]];
      pd.nominal[14] = 0.0;
      const Eigen::Vector3d f(pd.nominal[0], pd.nominal[1], pd.nominal[2]);
      if (f.norm() > 0) pd.force_direction = f / f.norm();
    } else {
      pd.nominal.fill(0.0);
    }
    s.posture_data.push_back(pd);
  }

  // Fingerprint: what defines the numbers.
  std::uint64_t h = 1469598103934665603ull;
  h = FnvString(h, WriteUrdfString(model.description()));
  h = FnvString(h, muscle);
  for (Eigen::Index i = 0; i < postures.size(); ++i) h = FnvDouble(h, postures.data()[i]);
  for (const Dimension& d : s.dims) {
    h = Fnv(h, &d.group, sizeof d.group);
    h = FnvDouble(h, d.a);
    h = FnvDouble(h, d.b);
    h = FnvDouble(h, d.scale);
    const int t = static_cast<int>(d.target) * 1000 + d.index + (d.absolute ? 500 : 0) +
                  static_cast<int>(d.distribution) * 100000;
    h = Fnv(h, &t, sizeof t);
  }
  for (Eigen::Index i = 0; i < s.fit_cholesky.size(); ++i)
    h = FnvDouble(h, s.fit_cholesky.data()[i]);
  for (Eigen::Index i = 0; i < s.fit_mean.size(); ++i) h = FnvDouble(h, s.fit_mean[i]);
  const long n = s.samples;
  h = Fnv(h, &n, sizeof n);
  h = Fnv(h, &s.options.seed, sizeof s.options.seed);
  const int flags = (s.options.sobol ? 1 : 0) + (s.exact ? 2 : 0);
  h = Fnv(h, &flags, sizeof flags);
  for (double v : {options.activation, options.statics.max_endpoint_fraction,
                   options.statics.max_joint_rotation, options.statics.leg_length,
                   options.statics.rank_tolerance, options.statics.excitation_tolerance})
    h = FnvDouble(h, v);
  s.fingerprint = h;
}

UncertaintyStudy::~UncertaintyStudy() = default;
UncertaintyStudy::UncertaintyStudy(const UncertaintyStudy&) = default;
UncertaintyStudy& UncertaintyStudy::operator=(const UncertaintyStudy&) = default;

long UncertaintyStudy::block_count() const {
  return (impl_->samples + kUncertaintyBlockSamples - 1) / kUncertaintyBlockSamples;
}
long UncertaintyStudy::evaluation_count() const {
  return impl_->samples * impl_->Rows() * static_cast<long>(impl_->postures.cols());
}
const std::vector<std::string>& UncertaintyStudy::groups() const { return impl_->groups; }
std::uint64_t UncertaintyStudy::fingerprint() const { return impl_->fingerprint; }
const Model& UncertaintyStudy::model() const { return impl_->model; }

namespace {

// 4 doubles (GCC/Clang vector extensions, as src/fast/simd.hpp): four lanes of a row's
// quantities at once. Each lane's sum runs over the samples in the order one scalar sum would,
// and no multiply-add is formed (the library is compiled for baseline x86-64), so every lane
// rounds as the scalar code does: the same bits. UNC_LOAD: 4 doubles from p (any alignment); a
// macro, as a 32-byte vector passed or returned by value draws GCC's -Wpsabi note.
typedef double UncV4 __attribute__((vector_size(32)));
typedef double UncV4u __attribute__((vector_size(32), aligned(8), may_alias));
#define UNC_LOAD(p) (*reinterpret_cast<const UncV4u*>(p))
#define UNC_STORE(p, v) (*reinterpret_cast<UncV4u*>(p) = (v))
// Lanes i, j, k, l of (a, b) (0-3: a's, 4-7: b's).
#if defined(__clang__)
#define UNC_SHUFFLE(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)
#else
#define UNC_SHUFFLE(a, b, i, j, k, l) __builtin_shuffle(a, b, UncMathI4{i, j, k, l})
#endif

// The hot sums are compiled twice, for AVX (4 doubles per instruction) and for the baseline; the
// loader picks the one the CPU runs (GNU ifunc, as src/fast/simd.hpp's ISOWRENCH_CLONES). "avx"
// and not x86-64-v3: without FMA no multiply-add is formed, so both round as scalar code does.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ISOWRENCH_NO_CLONES)
#define UNC_CLONES __attribute__((target_clones("avx", "default")))
#else
#define UNC_CLONES
#endif

// The Sobol sums of one input group over a block's samples, for the four lanes of vector k:
// ab_rows: that group's rows (kLanes doubles per sample), a_rows / b_rows: f(A) - c, f(B) - c
// (kW doubles per sample), code: 0 skip the sample, 1 every value finite, 2 lane by lane
// (finite: kSobolLanes flags per sample). first / total: sum b (ab - a) and sum (a - ab)^2 of
// the four lanes, in sample order.
UNC_CLONES void SobolLaneSums(const double* ab_rows, const double* a_rows, const double* b_rows,
                              int kW, const char* code, const char* finite, long count,
                              const double* c, int k, double* first_out, double* total_out) {
  UncV4 first = {0.0, 0.0, 0.0, 0.0}, total = first;
  const UncV4 ck = UNC_LOAD(c + 4 * k);
  for (long jj = 0; jj < count; ++jj) {
    if (code[jj] == 0) continue;
    const double* yab = ab_rows + jj * kLanes + 4 * k;
    const double* a = a_rows + jj * kW + 4 * k;
    const double* b = b_rows + jj * kW + 4 * k;
    if (code[jj] == 1) {
      const UncV4 ab = UNC_LOAD(yab) - ck, av = UNC_LOAD(a);
      first += UNC_LOAD(b) * (ab - av);
      const UncV4 e = av - ab;
      total += e * e;
    } else {
      for (int i = 0; i < 4 && 4 * k + i < kSobolLanes; ++i) {
        if (!finite[jj * kSobolLanes + 4 * k + i]) continue;
        const double ab = yab[i] - c[4 * k + i];
        first[i] += b[i] * (ab - a[i]);
        total[i] += (a[i] - ab) * (a[i] - ab);
      }
    }
  }
  for (int i = 0; i < 4; ++i) {
    first_out[i] = first[i];
    total_out[i] = total[i];
  }
}

// z[i] = NormalQuantile(p[i]), i < n: the central branch (|p - 0.5| <= 0.425, most draws) four
// at a time with the scalar's operations (CentralNormalQuantile), the tails by NormalQuantile.
UNC_CLONES void NormalQuantiles(const double* p, double* z, long n) {
  long i = 0;
  for (; i + 4 <= n; i += 4) {
    const UncV4 q = UNC_LOAD(p + i) - 0.5;
    const UncV4 central = CentralNormalQuantile(q);
    for (int l = 0; l < 4; ++l)
      z[i + l] = std::abs(q[l]) <= 0.425 ? central[l] : NormalQuantile(p[i + l]);
  }
  for (; i < n; ++i) z[i] = NormalQuantile(p[i]);
}

// v[i] = c * exp(a + x[i] * w), i < n (x == v allowed), four at a time (UncExpLanes): the
// arithmetic of IndependentValue, so the same bits.
UNC_CLONES void ExpValues(const double* x, double* v, long n, double a, double w, double c) {
  long i = 0;
  for (; i + 4 <= n; i += 4) {
    const UncV4 t = a + UNC_LOAD(x + i) * w;
    UncV4 e;
    UncExpLanes(reinterpret_cast<const double*>(&t), reinterpret_cast<double*>(&e));
    UNC_STORE(v + i, c * e);
  }
  for (; i < n; i += 4) {
    double t[4] = {0.0, 0.0, 0.0, 0.0}, e[4];
    for (int l = 0; l < 4 && i + l < n; ++l) t[l] = a + x[i + l] * w;
    UncExpLanes(t, e);
    for (int l = 0; l < 4 && i + l < n; ++l) v[i + l] = c * e[l];
  }
}

// The quantities of rows 0 .. n - 1 of a batch block (row r: sample r / rows, variant r % rows;
// W = scale[r] x results[r].wrench), four rows at a time: ReadingLaneQuantities and the flags of
// Impl::ReadingQuantities (world axes only for variants < stat_rows, else 0). Row (v, jj)'s
// kLanes doubles go to quantities + (v count + jj) kLanes, its flags to flags[v count + jj].
UNC_CLONES void RowQuantityLanes(const WrenchResult* results, const double* scale, long n, int rows,
                                 int stat_rows, long count, const double* R, const double* d,
                                 bool has_direction, double* quantities, unsigned char* flags,
                                 int* status) {
  const double big = std::numeric_limits<double>::max();
  for (long r0 = 0; r0 < n; r0 += 4) {
    const int lanes = static_cast<int>(std::min<long>(4, n - r0));
    UncV4 raw[6], factor;
    int state[4];
    for (int l = 0; l < 4; ++l) {
      const long r = r0 + std::min(l, lanes - 1);
      const double* w = results[r].wrench.data();
      for (int i = 0; i < 6; ++i) raw[i][l] = w[i];
      factor[l] = scale[r];
      state[l] = static_cast<int>(results[r].status);
    }
    // BlockRunner::Classify: 1 no equilibrium, 2 invalid or a non-finite W, else 0.
    UncMathI4 raw_finite = {-1, -1, -1, -1};
    UncV4 W[6];
    for (int i = 0; i < 6; ++i) {
      UncV4 a;
      UncAbs(raw[i], a);
      raw_finite &= a <= big;
      W[i] = factor * raw[i];
    }
    UncV4 y[kLanes];
    ReadingLaneQuantities(W, R, d, has_direction, y);
    UncV4 a6, a7, a8;
    UncAbs(y[6], a6);
    UncAbs(y[7], a7);
    UncAbs(y[8], a8);
    const UncMathI4 norms_finite = (a6 <= big) & (a7 <= big);
    UncMathI4 world_finite = norms_finite;
    for (int i = 9; i < 15; ++i) {
      UncV4 a;
      UncAbs(y[i], a);
      world_finite &= a <= big;
    }
    const UncMathI4 angle_finite = a8 <= big;
    long jj[4];
    int v[4];
    UncMathI4 world;
    for (int l = 0; l < 4; ++l) {
      const long r = r0 + std::min(l, lanes - 1);
      jj[l] = r / rows;
      v[l] = static_cast<int>(r % rows);
      world[l] = v[l] < stat_rows ? -1 : 0;
    }
    for (int i = 9; i < 15; ++i) y[i] = world ? y[i] : 0.0;
    const UncMathI4 finite = world ? world_finite : norms_finite;
    // Four 4 x 4 transposes: row l's lanes 4k .. 4k + 3 in out[l][k].
    UncV4 out[4][4];
    for (int k = 0; k < 4; ++k) {
      const UncV4 t0 = UNC_SHUFFLE(y[4 * k], y[4 * k + 1], 0, 4, 2, 6);
      const UncV4 t1 = UNC_SHUFFLE(y[4 * k], y[4 * k + 1], 1, 5, 3, 7);
      const UncV4 t2 = UNC_SHUFFLE(y[4 * k + 2], y[4 * k + 3], 0, 4, 2, 6);
      const UncV4 t3 = UNC_SHUFFLE(y[4 * k + 2], y[4 * k + 3], 1, 5, 3, 7);
      out[0][k] = UNC_SHUFFLE(t0, t2, 0, 1, 4, 5);
      out[1][k] = UNC_SHUFFLE(t1, t3, 0, 1, 4, 5);
      out[2][k] = UNC_SHUFFLE(t0, t2, 2, 3, 6, 7);
      out[3][k] = UNC_SHUFFLE(t1, t3, 2, 3, 6, 7);
    }
    for (int l = 0; l < lanes; ++l) {
      status[v[l] * count + jj[l]] =
          state[l] == static_cast<int>(StaticsStatus::kSelfMotion)                       ? 1
          : state[l] == static_cast<int>(StaticsStatus::kInvalidInput) || !raw_finite[l] ? 2
                                                                                         : 0;
      double* to = quantities + (v[l] * count + jj[l]) * kLanes;
      for (int k = 0; k < 4; ++k) UNC_STORE(to + 4 * k, out[l][k]);
      flags[v[l] * count + jj[l]] = static_cast<unsigned char>(
          (finite[l] ? kRowFinite : 0) | (angle_finite[l] ? kAngleFinite : 0));
    }
  }
}

// What the small-motion rule of a batch row needs besides the row (BlockRunner's
// SmallMotionFailsFromW): the posture's J (6 x m, column-major), tau and dtheta_from (m x
// (restrained + stiff), column-major), and the study's rows, columns and limits.
struct SmallMotionPlan {
  int m = 0;
  const int* restrained = nullptr;
  int n_restrained = 0;
  const int* stiff = nullptr;
  int n_stiff = 0;
  const double* J = nullptr;
  const double* tau = nullptr;
  const double* from = nullptr;
  const char* revolute = nullptr;
  double leg_length = 0.0, limit = 0.0, max_rotation = 0.0;
};
constexpr int kSmallMotionLaneDofs = 16;

// BlockRunner::SmallMotionFailsFromW for four rows at once (m <= kSmallMotionLaneDofs): the same
// operations in the same order in every lane, so the same decisions.
UNC_CLONES void SmallMotionLanes(const SmallMotionPlan& plan, const double* const* W,
                                 const double* const* s_t, const double* const* s_p,
                                 const double* scale, bool* fails) {
  const int m = plan.m;
  UncV4 b[6 + kSmallMotionLaneDofs];
  int k = 0;
  for (int i = 0; i < plan.n_restrained; ++i, ++k) {
    const int rr = plan.restrained[i];
    for (int l = 0; l < 4; ++l) b[k][l] = W[l][rr] / s_t[l][rr];
  }
  for (int i = 0; i < plan.n_stiff; ++i, ++k) {
    const int c = plan.stiff[i];
    const double* Jc = plan.J + 6 * c;
    UncV4 jtw = {0.0, 0.0, 0.0, 0.0}, w, sp;
    for (int r = 0; r < 6; ++r) {
      for (int l = 0; l < 4; ++l) w[l] = W[l][r];
      jtw += Jc[r] * w;
    }
    for (int l = 0; l < 4; ++l) sp[l] = s_p[l][c];
    b[k] = (plan.tau[c] - jtw) / sp;
  }
  const UncV4 factor = UNC_LOAD(scale);
  UncV4 dtheta[kSmallMotionLaneDofs];
  for (int i = 0; i < m; ++i) {
    UncV4 sum = {0.0, 0.0, 0.0, 0.0};
    for (int l = 0; l < k; ++l) sum += plan.from[l * m + i] * b[l];
    dtheta[i] = sum * factor;
  }
  UncV4 v[3] = {{0.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0}};
  for (int c = 0; c < m; ++c) {
    const double* Jc = plan.J + 6 * c;
    for (int i = 0; i < 3; ++i) v[i] += Jc[i] * dtheta[c];
  }
  UncV4 translation;
  UncSqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2], translation);
  UncMathI4 fail = {0, 0, 0, 0};
  if (plan.leg_length > 0) fail |= translation > plan.limit;
  for (int c = 0; c < m; ++c) {
    UncV4 a;
    UncAbs(dtheta[c], a);
    if (plan.revolute[c]) {
      fail |= a > plan.max_rotation;
    } else if (plan.leg_length > 0) {
      fail |= a > plan.limit;
    }
  }
  for (int l = 0; l < 4; ++l) fails[l] = fail[l] != 0;
}

// One thread's evaluation of blocks.
class BlockRunner {
 public:
  explicit BlockRunner(const UncertaintyStudy::Impl& s)
      : s_(s), data_(s.model), D_(static_cast<int>(s.dims.size())) {
    uA_.resize(static_cast<size_t>(D_));
    uB_.resize(static_cast<size_t>(D_));
    solve_.rank_tolerance = s.options.statics.rank_tolerance;
    solve_.excitation_tolerance = s.options.statics.excitation_tolerance;
    const long P = s.postures.cols();
    if (!s.exact) histograms_.assign(static_cast<size_t>(P * kQ), LogHistogram());
    // Without angle and reading inputs a row is a stiffness set and a force factor: those are
    // built directly (the sets the batch reads), not through RowInputs.
    sets_only_ = !s.kinematic && !s.has_post;
    if (sets_only_) PlanEntries();
  }

  // Block b: its records (one per posture) into `record` and, for exact percentiles, its
  // values into `values` (per posture and quantity).
  void Run(long b, double* record, std::vector<ValueVector>* values) {
    const long j0 = b * kUncertaintyBlockSamples;
    const long j1 = std::min(s_.samples, j0 + kUncertaintyBlockSamples);
    const long count = j1 - j0;
    const int rows = s_.Rows();
    const long P = s_.postures.cols();
    const int RS = s_.RecordSize();
    std::fill(record, record + P * RS, 0.0);
    count_ = count;
    if (sets_only_) {
      AssembleSets(j0, count);
    } else {
      AssembleRows(j0, count);
    }
    results_.resize(static_cast<size_t>(count * rows));
    quantities_.resize(static_cast<size_t>(count * rows * kLanes));
    status_.resize(static_cast<size_t>(count * rows));
    flags_.resize(static_cast<size_t>(count * rows));
    for (long p = 0; p < P; ++p) {
      EvaluatePosture(p, count * rows);
      Accumulate(p, count, record + p * RS, values);
    }
  }

  void MergeHistogramsInto(std::vector<LogHistogram>& total) const {
    for (size_t k = 0; k < histograms_.size(); ++k) total[k].Merge(histograms_[k]);
  }

 private:
  // Inputs of every row of the block as RowInputs (angle and reading inputs).
  void AssembleRows(long j0, long count) {
    const int rows = s_.Rows();
    inputs_.resize(static_cast<size_t>(count * rows));
    for (long jj = 0; jj < count; ++jj) {
      s_.Draw(j0 + jj, uA_.data(), s_.options.sobol ? uB_.data() : nullptr);
      RowInputs* row = &inputs_[static_cast<size_t>(jj * rows)];
      s_.Values(uA_.data(), valuesA_);
      s_.Assemble(valuesA_.data(), valuesA_.data(), -1, row[0]);
      if (!s_.options.sobol) continue;
      s_.Values(uB_.data(), valuesB_);
      s_.Assemble(valuesB_.data(), valuesB_.data(), -1, row[1]);
      for (int g = 0; g < s_.G(); ++g) {
        if (s_.group_sets_only[static_cast<size_t>(g)]) {
          s_.CopyRow(row[0], row[2 + g]);
          for (const Dimension& d : s_.dims)
            if (d.group == g)
              s_.Apply(d, valuesB_[static_cast<size_t>(&d - s_.dims.data())], row[2 + g]);
        } else {
          s_.Assemble(valuesA_.data(), valuesB_.data(), g, row[2 + g]);
        }
      }
    }
  }

  // What RowInputs holds for a row without angle and reading inputs: the stiffness set, the
  // force factor and the activation, with the arithmetic of Impl::Nominal and Impl::Apply.
  void SetTarget(const Dimension& d, double v, StiffnessSet& set, double& factor,
                 double& activation) const {
    switch (d.target) {
      case Target::kForceFactor: factor *= v; break;
      case Target::kActivation: activation = v; break;
      default: s_.ApplyToSet(d, v, set); break;
    }
  }
  void SetRow(const double* values_a, const double* values_b, int swap, StiffnessSet& set,
              double& factor, double& activation) const {
    set.s_t = s_.nominal_set.s_t;
    set.s_p = s_.nominal_set.s_p;
    factor = 1.0;
    activation = s_.nominal_activation;
    for (int k = 0; k < D_; ++k) {
      const Dimension& d = s_.dims[static_cast<size_t>(k)];
      SetTarget(d, d.group == swap ? values_b[k] : values_a[k], set, factor, activation);
    }
  }
  // The rows' stiffness sets (sets_, the batch's input) and W factors (scale_), as
  // AssembleRows + the batch path would make them.
  void AssembleSets(long j0, long count) {
    const int rows = s_.Rows();
    const size_t n = static_cast<size_t>(count * rows);
    sets_.resize(n, s_.nominal_set);  // allocated once per runner (and the last block)
    scale_.resize(n);
    const bool block_values = s_.fit_group < 0;
    if (block_values) BlockValues(j0, count);
    if (block_values && entry_plan_) {
      PlannedBlock(count);
      return;
    }
    const int matrices = s_.options.sobol ? 2 : 1;
    valuesA_.resize(static_cast<size_t>(D_));
    valuesB_.resize(static_cast<size_t>(D_));
    for (long jj = 0; jj < count; ++jj) {
      if (block_values) {
        for (int k = 0; k < D_; ++k) {
          const double* v = &block_values_[static_cast<size_t>((k * count + jj) * matrices)];
          valuesA_[static_cast<size_t>(k)] = v[0];
          if (matrices == 2) valuesB_[static_cast<size_t>(k)] = v[1];
        }
      } else {
        s_.Draw(j0 + jj, uA_.data(), s_.options.sobol ? uB_.data() : nullptr);
        s_.Values(uA_.data(), valuesA_);
        if (s_.options.sobol) s_.Values(uB_.data(), valuesB_);
      }
      StiffnessSet* set = &sets_[static_cast<size_t>(jj * rows)];
      double* scale = &scale_[static_cast<size_t>(jj * rows)];
      if (entry_plan_) {
        PlannedRows(set, scale);
        continue;
      }
      double factor_a, activation_a, factor, activation;
      SetRow(valuesA_.data(), valuesA_.data(), -1, set[0], factor_a, activation_a);
      scale[0] = s_.WScale(factor_a, activation_a);
      if (!s_.options.sobol) continue;
      SetRow(valuesB_.data(), valuesB_.data(), -1, set[1], factor, activation);
      scale[1] = s_.WScale(factor, activation);
      for (int g = 0; g < s_.G(); ++g) {
        StiffnessSet& to = set[2 + g];
        if (s_.group_sets_only[static_cast<size_t>(g)]) {
          // Row A with group g's values from B (Impl::CopyRow + Impl::Apply).
          to.s_t = set[0].s_t;
          to.s_p = set[0].s_p;
          factor = factor_a;
          activation = activation_a;
          for (int k = 0; k < D_; ++k) {
            const Dimension& d = s_.dims[static_cast<size_t>(k)];
            if (d.group == g)
              SetTarget(d, valuesB_[static_cast<size_t>(k)], to, factor, activation);
          }
        } else {
          SetRow(valuesA_.data(), valuesB_.data(), g, to, factor, activation);
        }
        scale[2 + g] = s_.WScale(factor, activation);
      }
    }
  }

  // When every dimension sets stiffness entries no other dimension sets, or the force factor, or
  // (one) the activation: the rows of a sample without copies. Each row's entries are those of
  // a fresh assembly from its sources (row A: A; row B: B; row A_B^g: group g from B, the others
  // from A), which is what CopyRow + Apply give when no two dimensions share an entry; entries
  // no dimension sets keep the model's value from sets_'s first fill. The arithmetic is Apply's.
  struct PlannedEntry {
    int dim = 0;
    int group = 0;
    bool s_p = false;       // else s_t
    int index = 0;          // entry
    bool absolute = false;  // the value itself, else nominal x value
    double nominal = 0.0;
  };
  void PlanEntries() {
    entry_plan_ = false;
    planned_.clear();
    force_dims_.clear();
    activation_dim_ = -1;
    const int m = s_.model.dof_count();
    std::vector<char> used(static_cast<size_t>(6 + m), 0);
    auto add = [&](int k, const Dimension& d, bool s_p, int index, bool absolute) {
      const size_t u = static_cast<size_t>(s_p ? 6 + index : index);
      if (used[u]) return false;
      used[u] = 1;
      PlannedEntry e;
      e.dim = k;
      e.group = d.group;
      e.s_p = s_p;
      e.index = index;
      e.absolute = absolute;
      e.nominal = s_p ? s_.nominal_set.s_p[index] : s_.nominal_set.s_t[index];
      planned_.push_back(e);
      return true;
    };
    for (int k = 0; k < D_; ++k) {
      const Dimension& d = s_.dims[static_cast<size_t>(k)];
      switch (d.target) {
        case Target::kTransducerStiffness:
          if (!add(k, d, false, d.index, d.absolute)) return;
          break;
        case Target::kTransducerRotationFactor:
          for (int r = 3; r < 6; ++r)
            if (!add(k, d, false, r, false)) return;
          break;
        case Target::kJointStiffness:
          for (int c : d.columns)
            if (!add(k, d, true, c, d.absolute)) return;
          break;
        case Target::kForceFactor: force_dims_.push_back(k); break;
        case Target::kActivation:
          if (activation_dim_ >= 0) return;
          activation_dim_ = k;
          break;
        case Target::kNone: break;
        default: return;
      }
    }
    entry_plan_ = true;
  }
  void PlannedRows(StiffnessSet* set, double* scale) const {
    const int rows = s_.Rows();
    const double* A = valuesA_.data();
    const double* B = valuesB_.data();
    for (const PlannedEntry& e : planned_) {
      // The entry from A and from B; row v takes B when v == 1 or v == 2 + its group.
      const double a = e.absolute ? A[e.dim] : e.nominal * A[e.dim];
      if (e.s_p) {
        set[0].s_p[e.index] = a;
        if (rows == 1) continue;
        const double b = e.absolute ? B[e.dim] : e.nominal * B[e.dim];
        set[1].s_p[e.index] = b;
        for (int v = 2; v < rows; ++v) set[v].s_p[e.index] = v - 2 == e.group ? b : a;
      } else {
        set[0].s_t[e.index] = a;
        if (rows == 1) continue;
        const double b = e.absolute ? B[e.dim] : e.nominal * B[e.dim];
        set[1].s_t[e.index] = b;
        for (int v = 2; v < rows; ++v) set[v].s_t[e.index] = v - 2 == e.group ? b : a;
      }
    }
    for (int v = 0; v < rows; ++v) {
      // Row v's source of dimension k: A, B, or B for group v - 2 only.
      auto value = [&](int k) {
        return v == 1 || s_.dims[static_cast<size_t>(k)].group == v - 2 ? B[k] : A[k];
      };
      double factor = 1.0;
      for (int k : force_dims_) factor *= value(k);
      const double activation =
          activation_dim_ < 0 ? s_.nominal_activation : value(activation_dim_);
      scale[v] = s_.WScale(factor, activation);
    }
  }

  // PlannedRows for every sample of the block, straight from block_values_: each planned entry
  // down the rows of every sample (A's value in every row, then B's in row B and in row
  // A_B^group), then the W factors; the same values as PlannedRows.
  void PlannedBlock(long count) {
    const int rows = s_.Rows();
    const int matrices = s_.options.sobol ? 2 : 1;
    StiffnessSet* sets = sets_.data();
    for (const PlannedEntry& e : planned_) {
      const double* v = &block_values_[static_cast<size_t>(e.dim * count * matrices)];
      for (long jj = 0; jj < count; ++jj) {
        StiffnessSet* set = sets + jj * rows;
        const double va = v[jj * matrices];
        const double a = e.absolute ? va : e.nominal * va;
        double b = a;
        if (rows > 1) {
          const double vb = v[jj * matrices + 1];
          b = e.absolute ? vb : e.nominal * vb;
        }
        if (e.s_p) {
          for (int r = 0; r < rows; ++r) set[r].s_p[e.index] = a;
          if (rows > 1) set[1].s_p[e.index] = set[2 + e.group].s_p[e.index] = b;
        } else {
          for (int r = 0; r < rows; ++r) set[r].s_t[e.index] = a;
          if (rows > 1) set[1].s_t[e.index] = set[2 + e.group].s_t[e.index] = b;
        }
      }
    }
    double* scale = scale_.data();
    const long n = count * rows;
    if (force_dims_.empty() && activation_dim_ < 0) {
      const double nominal = s_.WScale(1.0, s_.nominal_activation);
      std::fill(scale, scale + n, nominal);
      return;
    }
    for (long jj = 0; jj < count; ++jj) {
      for (int r = 0; r < rows; ++r) {
        // Row r's source of dimension k: A, B, or B for group r - 2 only (PlannedRows).
        auto value = [&](int k) {
          const bool from_b = r == 1 || s_.dims[static_cast<size_t>(k)].group == r - 2;
          return block_values_[static_cast<size_t>((k * count + jj) * matrices + (from_b ? 1 : 0))];
        };
        double factor = 1.0;
        for (int k : force_dims_) factor *= value(k);
        const double activation =
            activation_dim_ < 0 ? s_.nominal_activation : value(activation_dim_);
        scale[jj * rows + r] = s_.WScale(factor, activation);
      }
    }
  }

  // Every dimension's value of every sample of the block (without a fit: its transform needs a
  // whole sample), as Impl::Draw + Impl::Values compute them, dimension by dimension: the
  // normal quantiles four at a time (NormalQuantiles). block_values_[(k * count + jj) *
  // matrices + m]: dimension k, sample jj, matrix m (A, B).
  void BlockValues(long j0, long count) {
    const int matrices = s_.options.sobol ? 2 : 1;
    const long n = count * matrices;
    block_u_.resize(static_cast<size_t>(D_ * n));
    block_values_.resize(static_cast<size_t>(D_ * n));
    // Impl::Draw's words: word w is dimension w / matrices of matrix w % matrices.
    const int words = matrices * D_;
    for (long jj = 0; jj < count; ++jj) {
      for (int w = 0; w < words; w += 4) {
        const std::array<double, 4> r =
            PhiloxUniforms(s_.options.seed, static_cast<std::uint64_t>(j0 + jj), 0,
                           static_cast<std::uint64_t>(w / 4));
        for (int l = 0; l < 4 && w + l < words; ++l) {
          const int k = (w + l) / matrices, mx = (w + l) % matrices;
          block_u_[static_cast<size_t>(k * n + jj * matrices + mx)] = r[static_cast<size_t>(l)];
        }
      }
    }
    for (int k = 0; k < D_; ++k) {
      const Dimension& d = s_.dims[static_cast<size_t>(k)];
      const double* u = &block_u_[static_cast<size_t>(k * n)];
      double* v = &block_values_[static_cast<size_t>(k * n)];
      switch (d.distribution) {
        case InputDistribution::kNormal:
          NormalQuantiles(u, v, n);
          for (long i = 0; i < n; ++i) v[i] = d.a + d.b * v[i];
          break;
        case InputDistribution::kLogNormal:
          NormalQuantiles(u, v, n);
          ExpValues(v, v, n, 0.0, d.b, d.a);
          break;
        case InputDistribution::kUniform:
          for (long i = 0; i < n; ++i) v[i] = d.a + u[i] * (d.b - d.a);
          break;
        case InputDistribution::kLogUniform: ExpValues(u, v, n, d.a, d.b - d.a, 1.0); break;
      }
    }
  }

  // 0 valid, 1 no equilibrium, 2 invalid; small-motion failure as bit 4.
  void EvaluatePosture(long p, long n_rows) {
    const UncertaintyStudy::Impl::PostureData& pd = s_.posture_data[static_cast<size_t>(p)];
    const Eigen::VectorXd q = s_.postures.col(p);
    const int rows = s_.Rows();
    const int stat_rows = s_.options.sobol ? 2 : 1;
    if (!s_.kinematic) {
      // Batch path: every row shares the posture's kinematics; rows are stiffness sets.
      if (!sets_only_) {
        sets_.resize(static_cast<size_t>(n_rows), s_.nominal_set);
        for (long r = 0; r < n_rows; ++r)
          sets_[static_cast<size_t>(r)] = inputs_[static_cast<size_t>(r)].set;
      }
      BatchOptions batch;
      batch.threads = 1;
      batch.solve = solve_;
      // (a force model: activation inputs take the scalar path, so every row has the nominal one)
      EvaluateBatch(s_.model, q, s_.muscle, sets_, results_,
                    s_.EngineActivation(s_.nominal_activation), batch);
      if (sets_only_) {
        // Without reading inputs: every row's status and quantities four rows at a time (the
        // rows that are not valid are computed too and never read), then the small-motion rule
        // of the valid A and B rows.
        RowQuantityLanes(results_.data(), scale_.data(), n_rows, rows, stat_rows, count_,
                         pd.R_W_T.data(), pd.force_direction.data(), !pd.force_direction.isZero(),
                         quantities_.data(), flags_.data(), status_.data());
        const int m = static_cast<int>(pd.J.cols());
        if (m <= kLocalDofs) {
          // Four rows at a time (SmallMotionLanes: SmallMotionFailsFromW lane by lane).
          SmallMotionPlan plan;
          plan.m = m;
          plan.restrained = s_.restrained_rows.data();
          plan.n_restrained = static_cast<int>(s_.restrained_rows.size());
          plan.stiff = s_.stiff_columns.data();
          plan.n_stiff = static_cast<int>(s_.stiff_columns.size());
          plan.J = pd.J.data();
          plan.tau = pd.tau.data();
          plan.from = pd.dtheta_from.data();
          plan.revolute = s_.revolute.data();
          plan.leg_length = s_.leg_length;
          plan.limit = s_.options.statics.max_endpoint_fraction * s_.leg_length;
          plan.max_rotation = s_.options.statics.max_joint_rotation;
          const long n_stat = count_ * stat_rows;
          for (long i0 = 0; i0 < n_stat; i0 += 4) {
            const double* W[4];
            const double* s_t[4];
            const double* s_p[4];
            double scale[4];
            int* status[4];
            for (int l = 0; l < 4; ++l) {
              const long i = std::min(i0 + l, n_stat - 1);  // (the last rows repeated)
              const long jj = i / stat_rows;
              const int v = static_cast<int>(i % stat_rows);
              const size_t r = static_cast<size_t>(jj * rows + v);
              W[l] = results_[r].wrench.data();
              s_t[l] = sets_[r].s_t.data();
              s_p[l] = sets_[r].s_p.data();
              scale[l] = scale_[r];
              status[l] = &status_[Status(v, jj)];
            }
            bool fails[4];
            SmallMotionLanes(plan, W, s_t, s_p, scale, fails);
            for (int l = 0; l < 4 && i0 + l < n_stat; ++l)
              if (*status[l] == 0 && fails[l]) *status[l] |= 4;
          }
          return;
        }
        for (int v = 0; v < stat_rows; ++v) {
          for (long jj = 0; jj < count_; ++jj) {
            int& status = status_[Status(v, jj)];
            const size_t r = static_cast<size_t>(jj * rows + v);
            if (status == 0 &&
                SmallMotionFailsFromW(pd, results_[r].wrench.data(), sets_[r], scale_[r]))
              status |= 4;
          }
        }
        return;
      }
      long r = 0;
      for (long jj = 0; jj < count_; ++jj) {
        for (int v = 0; v < rows; ++v, ++r) {
          const WrenchResult& w = results_[static_cast<size_t>(r)];
          const RowInputs& row = inputs_[static_cast<size_t>(r)];
          int status = Classify(w);
          // A_B^i rows serve the Sobol sums only: no small-motion check, no world axes.
          const bool statistics = v < stat_rows;
          if (status == 0 && statistics &&
              SmallMotionFailsFromW(pd, w.wrench.data(), row.set,
                                    s_.WScale(row.factor, row.activation)))
            status |= 4;
          if (status == 0 || status == 4) {
            flags_[Status(v, jj)] = static_cast<unsigned char>(
                s_.Quantities(pd, w.wrench, row, Row(v, jj), statistics));
          }
          status_[static_cast<size_t>(v * count_ + jj)] = status;
        }
      }
      return;
    }
    // Scalar path: rows whose posture, path points or (force model) activation differ from the
    // previous row's recompute kinematics.
    bool have_kinematics = false;
    long r = 0;
    for (long jj = 0; jj < count_; ++jj) {
      for (int v = 0; v < rows; ++v, ++r) {
        const RowInputs& row = inputs_[static_cast<size_t>(r)];
        qr_ = q + row.dq;
        const double activation = s_.EngineActivation(row.activation);
        if (!have_kinematics || qr_ != last_q_ || activation != last_activation_ ||
            (s_.has_points && row.points != last_points_)) {
          if (s_.has_points) {
            SetPathPointOffsets(s_.model, data_, s_.muscle, row.points);
            last_points_ = row.points;
          }
          // A force model's activation outside [0, 1] (a normal's tail): no force, invalid.
          kinematics_ok_ = activation >= 0.0 && activation <= 1.0 &&
                           ComputeKinematics(s_.model, data_, qr_, s_.muscle, activation);
          J_ = data_.jacobian();
          last_q_ = qr_;
          last_activation_ = activation;
          have_kinematics = true;
        }
        const WrenchResult w = kinematics_ok_ ? SolveStatics(s_.model, data_, row.set, solve_)
                                              : WrenchResult{};  // coincident path points
        int status = Classify(w);
        double* y = Row(v, jj);
        if (status == 0 && v >= stat_rows) {
          flags_[Status(v, jj)] =
              static_cast<unsigned char>(s_.Quantities(pd, w.wrench, row, y, false));
        } else if (status == 0) {
          dtheta_ = data_.dtheta();
          dtheta_ *= s_.WScale(row.factor, row.activation);
          if (s_.SmallMotionFails(J_, dtheta_)) status |= 4;
          flags_[Status(v, jj)] = static_cast<unsigned char>(s_.Quantities(pd, w.wrench, row, y));
        }
        status_[static_cast<size_t>(v * count_ + jj)] = status;
      }
    }
  }

  // The small-motion rule of a batch row (activation 1, W factor `scale`) from its W: dtheta =
  // scale x dtheta_from b, b = [W_r / s_r; (tau - J^T W)_c / s_c] (the reconstruction in the
  // constructor), then Impl::SmallMotionFails' tests, in plain loops (Eigen's general products
  // cost ~4x more at these sizes; the rounding differs from theirs in the last bits, which only
  // moves the rule's threshold by as much). The vectors are on the stack up to kLocalDofs.
  static constexpr int kLocalDofs = kSmallMotionLaneDofs;
  bool SmallMotionFailsFromW(const UncertaintyStudy::Impl::PostureData& pd, const double* W,
                             const StiffnessSet& set, double scale) {
    const int m = static_cast<int>(pd.J.cols());
    double b_local[6 + kLocalDofs], dtheta_local[kLocalDofs];
    if (m > kLocalDofs) {
      b_.resize(6 + m);
      dtheta_.resize(m);
    }
    double* b = m > kLocalDofs ? b_.data() : b_local;
    double* dtheta = m > kLocalDofs ? dtheta_.data() : dtheta_local;
    int k = 0;
    for (int rr : s_.restrained_rows) b[k++] = W[rr] / set.s_t[rr];
    for (int c : s_.stiff_columns) {
      const double* Jc = pd.J.col(c).data();
      double jtw = 0.0;
      for (int i = 0; i < 6; ++i) jtw += Jc[i] * W[i];
      b[k++] = (pd.tau[c] - jtw) / set.s_p[c];
    }
    const double* from = pd.dtheta_from.data();
    for (int i = 0; i < m; ++i) {
      double sum = 0.0;
      for (int l = 0; l < k; ++l) sum += from[l * m + i] * b[l];
      dtheta[i] = sum * scale;
    }
    // Impl::SmallMotionFails.
    double v[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < m; ++c) {
      const double* Jc = pd.J.col(c).data();
      for (int i = 0; i < 3; ++i) v[i] += Jc[i] * dtheta[c];
    }
    const double translation = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double limit = s_.options.statics.max_endpoint_fraction * s_.leg_length;
    if (s_.leg_length > 0 && translation > limit) return true;
    for (int c = 0; c < m; ++c) {
      const double a = std::abs(dtheta[c]);
      if (s_.revolute[static_cast<size_t>(c)]) {
        if (a > s_.options.statics.max_joint_rotation) return true;
      } else if (s_.leg_length > 0 && a > limit) {
        return true;
      }
    }
    return false;
  }

  // A block's quantities: variant v (A, B, A_B^1 ...), sample jj, kLanes doubles in lane order
  // (so the sums below take four quantities of a row at once). Statuses: variant, sample.
  size_t Status(int v, long jj) const { return static_cast<size_t>(v * count_ + jj); }
  double* Row(int v, long jj) {
    return &quantities_[static_cast<size_t>((static_cast<long>(v) * count_ + jj) * kLanes)];
  }

  static int Classify(const WrenchResult& w) {
    if (w.status == StaticsStatus::kSelfMotion) return 1;
    if (w.status == StaticsStatus::kInvalidInput || !w.wrench.allFinite()) return 2;
    return 0;
  }

  void Accumulate(long p, long count, double* rec, std::vector<ValueVector>* values) {
    const int G = s_.G();
    const double* nominal = s_.posture_data[static_cast<size_t>(p)].nominal.data();
    double c_lanes[kLanes] = {};
    for (int q = 0; q < kQ; ++q) c_lanes[kLaneOf[q]] = nominal[q];
    UncV4 c[4];
    for (int k = 0; k < 4; ++k) c[k] = UNC_LOAD(c_lanes + 4 * k);
    int quantity_of[kLanes] = {};
    for (int q = 0; q < kQ; ++q) quantity_of[kLaneOf[q]] = q;
    double* per_q = rec + kCounts;
    double* sobol = rec + kCounts + kQ * kPerQuantity;
    const int stat_rows = s_.options.sobol ? 2 : 1;
    const int rows = s_.Rows();
    const UncV4 zero = {0.0, 0.0, 0.0, 0.0}, one = {1.0, 1.0, 1.0, 1.0};
    // Counts; a row with a non-finite quantity (the angle aside) is invalid.
    for (int v = 0; v < stat_rows; ++v) {
      for (long jj = 0; jj < count; ++jj) {
        int& st = status_[Status(v, jj)];
        if ((st & 3) == 0 && !(flags_[Status(v, jj)] & kRowFinite)) st = 2;
        rec[0] += 1;
        if ((st & 3) == 1) {
          rec[2] += 1;
        } else if ((st & 3) == 2) {
          rec[3] += 1;
        } else {
          rec[1] += 1;
          if (st & 4) rec[4] += 1;
        }
      }
    }
    // Moments and percentile data per quantity (lane), over the valid A and B rows, A's then
    // B's in sample order, as one scalar sum per quantity would add them. In a valid row only
    // the angle can be non-finite (kAngleFinite).
    UncV4 n[4] = {zero, zero, zero, zero}, s1[4] = {zero, zero, zero, zero},
          s2[4] = {zero, zero, zero, zero};
    double* out[kLanes] = {};
    LogHistogram* histogram[kLanes] = {};
    for (int l = 0; l < kLanes - 1; ++l) {
      const size_t i = static_cast<size_t>(p * kQ + quantity_of[l]);
      if (s_.exact) {
        ValueVector& kept = (*values)[i];
        const size_t old = kept.size();
        kept.resize(old + static_cast<size_t>(stat_rows * count));
        out[l] = kept.data() + old;
      } else {
        histogram[l] = &histograms_[i];
      }
    }
    long kept_rows = 0, kept_angles = 0;
    for (int v = 0; v < stat_rows; ++v) {
      for (long jj = 0; jj < count; ++jj) {
        if ((status_[Status(v, jj)] & 3) != 0) continue;
        const double* y = Row(v, jj);
        const bool angle = (flags_[Status(v, jj)] & kAngleFinite) != 0;
        for (int k = 0; k < 4; ++k) {
          if (k == 2 && !angle) {
            for (int i = 1; i < 4; ++i) {
              const double d = y[8 + i] - c_lanes[8 + i];
              n[2][i] += 1.0;
              s1[2][i] += d;
              s2[2][i] += d * d;
            }
            continue;
          }
          const UncV4 d = UNC_LOAD(y + 4 * k) - c[k];
          n[k] += one;
          s1[k] += d;
          s2[k] += d * d;
        }
        if (s_.exact) {
          // Every lane but the angle's keeps a value of every valid row: one running index;
          // the angle's is kept only when finite (else overwritten next, or trimmed below).
          for (int l = 0; l < 8; ++l) out[l][kept_rows] = y[l];
          for (int l = 9; l < kLanes - 1; ++l) out[l][kept_rows] = y[l];
          ++kept_rows;
          out[8][kept_angles] = y[8];
          kept_angles += angle ? 1 : 0;
        } else {
          for (int l = 0; l < kLanes - 1; ++l)
            if (l != 8 || angle) histogram[l]->Add(y[l]);
        }
      }
    }
    for (int l = 0; l < kLanes - 1; ++l) {
      const int q = quantity_of[l];
      per_q[q * kPerQuantity + 0] += n[l / 4][l % 4];
      per_q[q * kPerQuantity + 1] += s1[l / 4][l % 4];
      per_q[q * kPerQuantity + 2] += s2[l / 4][l % 4];
      if (s_.exact) {
        ValueVector& kept = (*values)[static_cast<size_t>(p * kQ + q)];
        kept.resize(static_cast<size_t>(out[l] + (l == 8 ? kept_angles : kept_rows) - kept.data()));
      }
    }
    if (!s_.options.sobol) return;
    // Sobol sums over the samples whose every row is valid and finite for the quantity (lanes
    // 0-8 of three vectors; lanes 9-11 ride along and are dropped). Per sample: 0 skipped, 1
    // every value finite, 2 each lane decided on its own (finite_lane_).
    constexpr int kSobolVectors = (kSobolLanes + 3) / 4;
    constexpr int kW = 4 * kSobolVectors;
    code_.resize(static_cast<size_t>(count));
    dA_.resize(static_cast<size_t>(count * kW));
    dB_.resize(static_cast<size_t>(count * kW));
    finite_lane_.resize(static_cast<size_t>(count * kSobolLanes));
    double ns[kW] = {};
    long fast = 0;
    for (long jj = 0; jj < count; ++jj) {
      bool all = true;
      int flags = kAllFinite;
      for (int v = 0; v < rows; ++v) {
        all = all && (status_[Status(v, jj)] & 3) == 0;
        flags &= flags_[Status(v, jj)];
      }
      code_[static_cast<size_t>(jj)] = static_cast<char>(!all ? 0 : flags == kAllFinite ? 1 : 2);
      if (!all) continue;
      const double* yA = Row(0, jj);
      const double* yB = Row(1, jj);
      for (int l = 0; l < kW; ++l) {
        dA_[static_cast<size_t>(jj * kW + l)] = yA[l] - c_lanes[l];
        dB_[static_cast<size_t>(jj * kW + l)] = yB[l] - c_lanes[l];
      }
      if (flags == kAllFinite) {
        ++fast;
        continue;
      }
      for (int l = 0; l < kSobolLanes; ++l) {
        bool finite = true;
        for (int v = 0; v < rows; ++v) finite = finite && std::isfinite(Row(v, jj)[l]);
        finite_lane_[static_cast<size_t>(jj * kSobolLanes + l)] = finite;
        if (finite) ns[l] += 1.0;
      }
    }
    for (int l = 0; l < kSobolLanes; ++l)
      per_q[quantity_of[l] * kPerQuantity + 3] += ns[l] + static_cast<double>(fast);
    for (int g = 0; g < G; ++g) {
      for (int k = 0; k < kSobolVectors; ++k) {
        double first[4], total[4];
        SobolLaneSums(Row(2 + g, 0), dA_.data(), dB_.data(), kW, code_.data(), finite_lane_.data(),
                      count, c_lanes, k, first, total);
        for (int i = 0; i < 4 && 4 * k + i < kSobolLanes; ++i) {
          const int q = quantity_of[4 * k + i];
          sobol[(g * kQ + q) * 2 + 0] += first[i];
          sobol[(g * kQ + q) * 2 + 1] += total[i];
        }
      }
    }
  }

  const UncertaintyStudy::Impl& s_;
  Data data_;
  int D_;
  SolveOptions solve_;
  bool sets_only_ = false;
  std::vector<double> uA_, uB_, valuesA_, valuesB_;
  ValueVector block_u_, block_values_;  // BlockValues
  bool entry_plan_ = false;             // PlanEntries
  std::vector<PlannedEntry> planned_;
  std::vector<int> force_dims_;
  int activation_dim_ = -1;
  Eigen::VectorXd b_, dtheta_, qr_, last_q_;
  double last_activation_ = 1.0;
  Eigen::Matrix3Xd last_points_;
  std::vector<RowInputs> inputs_;
  std::vector<StiffnessSet> sets_;
  ValueVector scale_;
  std::vector<WrenchResult> results_;
  ValueVector quantities_;
  std::vector<int> status_;
  std::vector<unsigned char> flags_;  // Quantities' kRowFinite / kAngleFinite, as status_
  std::vector<char> code_, finite_lane_;
  ValueVector dA_, dB_;  // f(A) - c, f(B) - c per sample, kW lanes
  long count_ = 0;
  bool kinematics_ok_ = true;
  Matrix6Xd J_;
  std::vector<LogHistogram> histograms_;
};

// Partial data layout: records (blocks x postures x RecordSize doubles); then exact values
// (per block, posture, quantity: count then values) or histograms (per posture and quantity).
constexpr char kPartialMagic[8] = {'I', 'W', 'U', 'N', 'C', 'P', '0', '1'};

}  // namespace

namespace {

// What blocks [first, last) produce before they become a partial's bytes: the records (blocks x
// postures x RecordSize), per block the kept values (postures x quantities), or the merged
// histograms.
struct BlockOutput {
  std::vector<double> records;
  std::vector<std::vector<ValueVector>> values;
  std::vector<LogHistogram> histograms;
};

BlockOutput RunUncertaintyBlocksOutput(const UncertaintyStudy& study, long first_block,
                                       long last_block, int threads,
                                       const std::function<void(long, long)>& progress) {
  const UncertaintyStudy::Impl& s = study.impl();
  if (first_block < 0 || last_block > study.block_count() || first_block > last_block) {
    throw Error("uncertainty: blocks [" + std::to_string(first_block) + ", " +
                std::to_string(last_block) + ") are outside the study's [0, " +
                std::to_string(study.block_count()) + ")");
  }
  if (threads < 1) throw Error("uncertainty: threads must be >= 1");
  const long n_blocks = last_block - first_block;
  const long P = s.postures.cols();
  const int RS = s.RecordSize();
  std::vector<double> records(static_cast<size_t>(n_blocks * P * RS), 0.0);
  std::vector<std::vector<ValueVector>> values(static_cast<size_t>(n_blocks));
  std::vector<LogHistogram> histograms(s.exact ? 0 : static_cast<size_t>(P * kQ));
  std::atomic<long> next{0};
  std::atomic<long> done{0};
  const long per_sample = s.Rows() * P;
  long total = 0;
  for (long b = first_block; b < last_block; ++b)
    total +=
        std::min(kUncertaintyBlockSamples, s.samples - b * kUncertaintyBlockSamples) * per_sample;
  std::mutex merge_mutex;
  std::exception_ptr failure;
  std::atomic<int> finished{0};
  auto work = [&]() {
    try {
      BlockRunner runner(s);
      for (;;) {
        const long k = next.fetch_add(1);
        if (k >= n_blocks) break;
        const long b = first_block + k;
        if (s.exact) {
          values[static_cast<size_t>(k)].assign(static_cast<size_t>(P * kQ), {});
          for (ValueVector& v : values[static_cast<size_t>(k)])
            v.reserve(static_cast<size_t>(2 * kUncertaintyBlockSamples));
        }
        runner.Run(b, &records[static_cast<size_t>(k * P * RS)], &values[static_cast<size_t>(k)]);
        done.fetch_add(
            std::min(kUncertaintyBlockSamples, s.samples - b * kUncertaintyBlockSamples) *
            per_sample);
      }
      if (!s.exact) {
        std::lock_guard<std::mutex> lock(merge_mutex);
        runner.MergeHistogramsInto(histograms);  // integer counts: any order gives the same
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(merge_mutex);
      if (!failure) failure = std::current_exception();
      next.store(n_blocks);
    }
    finished.fetch_add(1);
  };
  const int n_threads = static_cast<int>(std::max<long>(1, std::min<long>(threads, n_blocks)));
  std::vector<std::thread> workers;
  for (int t = 0; t < n_threads; ++t) workers.emplace_back(work);
  // Progress on the calling thread, every 0.1 s until the workers are done.
  while (progress && finished.load() < n_threads) {
    progress(done.load(), total);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  for (std::thread& t : workers) t.join();
  if (failure) std::rethrow_exception(failure);
  if (progress) progress(total, total);
  BlockOutput output;
  output.records = std::move(records);
  output.values = std::move(values);
  output.histograms = std::move(histograms);
  return output;
}

// The statistics from the records summed in block order, the kept values of each posture and
// quantity in block order (exact) or the merged histograms: FinishUncertainty's second half.
UncertaintyResult Statistics(const UncertaintyStudy& study, const std::vector<double>& sum,
                             std::vector<ValueVector>& values,
                             const std::vector<LogHistogram>& histograms);

}  // namespace

UncertaintyPartial RunUncertaintyBlocks(const UncertaintyStudy& study, long first_block,
                                        long last_block, int threads,
                                        const std::function<void(long, long)>& progress) {
  const UncertaintyStudy::Impl& s = study.impl();
  BlockOutput output =
      RunUncertaintyBlocksOutput(study, first_block, last_block, threads, progress);
  const long n_blocks = last_block - first_block;
  const long P = s.postures.cols();
  const std::vector<double>& records = output.records;
  const std::vector<std::vector<ValueVector>>& values = output.values;
  const std::vector<LogHistogram>& histograms = output.histograms;
  UncertaintyPartial partial;
  partial.fingerprint = s.fingerprint;
  partial.first_block = first_block;
  partial.last_block = last_block;
  std::string& out = partial.data;
  size_t bytes = records.size() * sizeof(double);
  if (s.exact) {
    for (const std::vector<ValueVector>& block : values)
      for (const ValueVector& v : block) bytes += sizeof(std::uint64_t) + v.size() * sizeof(double);
  }
  out.reserve(bytes);
  out.append(reinterpret_cast<const char*>(records.data()), records.size() * sizeof(double));
  if (s.exact) {
    for (long k = 0; k < n_blocks; ++k) {
      for (long i = 0; i < P * kQ; ++i) {
        const ValueVector& v = values[static_cast<size_t>(k)][static_cast<size_t>(i)];
        Put(out, static_cast<std::uint64_t>(v.size()));
        out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
      }
    }
  } else {
    for (const LogHistogram& h : histograms) h.Write(out);
  }
  return partial;
}

std::string UncertaintyPartial::ToBytes() const {
  std::string out(kPartialMagic, sizeof kPartialMagic);
  Put(out, fingerprint);
  Put(out, first_block);
  Put(out, last_block);
  Put(out, static_cast<std::uint64_t>(data.size()));
  out += data;
  return out;
}

UncertaintyPartial UncertaintyPartial::FromBytes(const std::string& bytes) {
  if (bytes.size() < sizeof kPartialMagic ||
      std::memcmp(bytes.data(), kPartialMagic, sizeof kPartialMagic) != 0)
    throw Error("uncertainty partial: these bytes are not a partial result (no header)");
  const char* p = bytes.data() + sizeof kPartialMagic;
  const char* end = bytes.data() + bytes.size();
  UncertaintyPartial partial;
  std::uint64_t size = 0;
  p = Get(p, end, &partial.fingerprint);
  p = Get(p, end, &partial.first_block);
  p = Get(p, end, &partial.last_block);
  p = Get(p, end, &size);
  if (static_cast<std::uint64_t>(end - p) != size)
    throw Error("uncertainty partial: truncated bytes");
  partial.data.assign(p, static_cast<size_t>(size));
  return partial;
}

const char* UncertaintyQuantityName(int q) {
  static const char* const kNames[kQ] = {"fx",
                                         "fy",
                                         "fz",
                                         "mx",
                                         "my",
                                         "mz",
                                         "world_fx",
                                         "world_fy",
                                         "world_fz",
                                         "world_mx",
                                         "world_my",
                                         "world_mz",
                                         "force_magnitude",
                                         "moment_magnitude",
                                         "direction_angle"};
  return q >= 0 && q < kQ ? kNames[q] : "?";
}

const char* UncertaintyQuantityUnit(int q) {
  if (q == 14) return "rad";
  if (q == 12 || q < 3 || (q >= 6 && q < 9)) return "N";
  return "N·m";
}

namespace {

// The histogram counts of v[0, n) (kept values: never NaN): x in [lower, upper] falls in bin
// (x - lower) / width truncated, at most the last (bin 0 when width is not > 0); four values at
// a time (the same division and truncation per value as one at a time).
UNC_CLONES void HistogramCounts(const double* v, long n, double lower, double upper, double width,
                                long* counts) {
  constexpr long kLast = kUncertaintyHistogramBins - 1;
  long i = 0;
  if (width > 0) {
    const double last = static_cast<double>(kLast);
    for (; i + 4 <= n; i += 4) {
      const UncV4 x = UNC_LOAD(v + i);
      const UncMathI4 in = (x >= lower) & (x <= upper);
      UncV4 k = (x - lower) / width;
      k = k < last ? k : last;
      for (int l = 0; l < 4; ++l)
        if (in[l]) ++counts[static_cast<long>(k[l])];
    }
  }
  for (; i < n; ++i) {
    const double x = v[i];
    if (!(x >= lower && x <= upper)) continue;
    long k = width > 0 ? static_cast<long>((x - lower) / width) : 0;
    k = std::clamp<long>(k, 0, kLast);
    ++counts[k];
  }
}

// The smallest and largest of v[0, n) as folds of std::min / std::max from +-inf in order would
// give them: four lanes at a time; a zero extreme (where +0 and -0 compare equal, so the fold's
// first one wins) is found again by the ordered fold. Other equal values have equal bits.
UNC_CLONES void Extremes(const double* v, long n, double* lo_out, double* hi_out) {
  const double inf = std::numeric_limits<double>::infinity();
  UncV4 lo = {inf, inf, inf, inf}, hi = -lo;
  long i = 0;
  for (; i + 4 <= n; i += 4) {
    const UncV4 x = UNC_LOAD(v + i);
    lo = x < lo ? x : lo;
    hi = x > hi ? x : hi;
  }
  double l = inf, h = -inf;
  for (int k = 0; k < 4; ++k) {
    l = std::min(l, lo[k]);
    h = std::max(h, hi[k]);
  }
  for (; i < n; ++i) {
    l = std::min(l, v[i]);
    h = std::max(h, v[i]);
  }
  if (l == 0.0 || h == 0.0) {
    l = inf;
    h = -inf;
    for (long j = 0; j < n; ++j) {
      l = std::min(l, v[j]);
      h = std::max(h, v[j]);
    }
  }
  *lo_out = l;
  *hi_out = h;
}

double HistogramPercentile(const LogHistogram& h, double level) {
  const std::uint64_t n = h.count();
  const double pos = (static_cast<double>(n) - 1.0) * level;
  const std::uint64_t lo = static_cast<std::uint64_t>(std::floor(pos));
  const std::uint64_t hi = std::min(n - 1, lo + 1);
  const double a = h.ValueAt(lo), b = h.ValueAt(hi);
  return a + (pos - static_cast<double>(lo)) * (b - a);
}

}  // namespace

UncertaintyResult FinishUncertainty(const UncertaintyStudy& study,
                                    const std::vector<UncertaintyPartial>& partials_in) {
  const UncertaintyStudy::Impl& s = study.impl();
  std::vector<const UncertaintyPartial*> partials;
  for (const UncertaintyPartial& p : partials_in) {
    if (p.fingerprint != s.fingerprint) {
      throw Error("uncertainty: a partial result (blocks " + std::to_string(p.first_block) + "-" +
                  std::to_string(p.last_block) +
                  ") is of another study (model, inputs, postures or options differ)");
    }
    partials.push_back(&p);
  }
  std::sort(partials.begin(), partials.end(),
            [](const UncertaintyPartial* a, const UncertaintyPartial* b) {
              return a->first_block < b->first_block;
            });
  long expected = 0;
  for (const UncertaintyPartial* p : partials) {
    if (p->first_block != expected) {
      throw Error(p->first_block > expected
                      ? "uncertainty: blocks " + std::to_string(expected) + "-" +
                            std::to_string(p->first_block) + " are missing from the partials"
                      : "uncertainty: block " + std::to_string(p->first_block) +
                            " is in two partials");
    }
    expected = p->last_block;
  }
  if (expected != study.block_count()) {
    throw Error("uncertainty: blocks " + std::to_string(expected) + "-" +
                std::to_string(study.block_count()) + " are missing from the partials");
  }
  const long P = s.postures.cols();
  const int RS = s.RecordSize();
  std::vector<double> sum(static_cast<size_t>(P * RS), 0.0);
  std::vector<ValueVector> values(s.exact ? static_cast<size_t>(P * kQ) : 0);
  std::vector<LogHistogram> histograms(s.exact ? 0 : static_cast<size_t>(P * kQ));
  for (const UncertaintyPartial* part : partials) {
    const long n_blocks = part->last_block - part->first_block;
    const size_t record_bytes = static_cast<size_t>(n_blocks * P * RS) * sizeof(double);
    if (part->data.size() < record_bytes) throw Error("uncertainty partial: truncated records");
    const double* rec = reinterpret_cast<const double*>(part->data.data());
    std::vector<double> aligned(rec, rec + n_blocks * P * RS);  // (alignment-safe copy)
    // Blocks in order: each block's record added to the running sum.
    for (long k = 0; k < n_blocks; ++k) {
      for (long i = 0; i < P * RS; ++i)
        sum[static_cast<size_t>(i)] += aligned[static_cast<size_t>(k * P * RS + i)];
    }
  }
  // The values each quantity keeps: its count of valid values (one allocation each).
  for (long p = 0; s.exact && p < P; ++p) {
    for (int q = 0; q < kQ; ++q) {
      const double n = sum[static_cast<size_t>(p * RS + kCounts + q * kPerQuantity)];
      if (n > 0 && n < 1e12)
        values[static_cast<size_t>(p * kQ + q)].reserve(static_cast<size_t>(n));
    }
  }
  for (const UncertaintyPartial* part : partials) {
    const long n_blocks = part->last_block - part->first_block;
    const size_t record_bytes = static_cast<size_t>(n_blocks * P * RS) * sizeof(double);
    const char* p = part->data.data() + record_bytes;
    const char* end = part->data.data() + part->data.size();
    if (s.exact) {
      for (long k = 0; k < n_blocks; ++k) {
        for (long i = 0; i < P * kQ; ++i) {
          std::uint64_t n = 0;
          p = Get(p, end, &n);
          if (static_cast<std::uint64_t>(end - p) < n * sizeof(double))
            throw Error("uncertainty partial: truncated values");
          ValueVector& v = values[static_cast<size_t>(i)];
          const size_t old = v.size();
          v.resize(old + static_cast<size_t>(n));
          // n == 0 leaves an empty vector's data() null: memcpy's pointers must not be (UBSan).
          if (n > 0) std::memcpy(v.data() + old, p, static_cast<size_t>(n) * sizeof(double));
          p += n * sizeof(double);
        }
      }
    } else {
      for (long i = 0; i < P * kQ; ++i) {
        LogHistogram h;
        p = h.Read(p, end);
        histograms[static_cast<size_t>(i)].Merge(h);
      }
    }
  }
  return Statistics(study, sum, values, histograms);
}

namespace {

UncertaintyResult Statistics(const UncertaintyStudy& study, const std::vector<double>& sum,
                             std::vector<ValueVector>& values,
                             const std::vector<LogHistogram>& histograms) {
  const UncertaintyStudy::Impl& s = study.impl();
  const long P = s.postures.cols();
  const int RS = s.RecordSize();
  const int G = s.G();
  UncertaintyResult result;
  result.model = s.model.name();
  result.muscle = s.muscle_name;
  result.groups = s.groups;
  result.samples = s.samples;
  result.evaluations = study.evaluation_count();
  result.seed = s.options.seed;
  result.sobol = s.options.sobol;
  result.exact_percentiles = s.exact;
  result.percentile_method =
      s.exact ? "exact order statistics of the valid samples (linear interpolation between "
                "neighbours, Hyndman-Fan type 7)"
              : "log-linear histogram of the valid samples (512 bins per octave: each "
                "percentile within 2^-10 = 0.098 % of its magnitude), merged exactly";
  result.notes = s.notes;
  for (long p = 0; p < P; ++p) {
    const UncertaintyStudy::Impl::PostureData& pd = s.posture_data[static_cast<size_t>(p)];
    const double* rec = &sum[static_cast<size_t>(p * RS)];
    PostureUncertainty out;
    out.posture = s.postures.col(p);
    out.nominal = pd.nominal;
    out.nominal_status = pd.nominal_status;
    out.samples = static_cast<long>(rec[0]);
    out.valid = static_cast<long>(rec[1]);
    out.no_equilibrium = static_cast<long>(rec[2]);
    out.invalid = static_cast<long>(rec[3]);
    out.small_motion_failed = static_cast<long>(rec[4]);
    const double* per_q = rec + kCounts;
    const double* sob = rec + kCounts + kQ * kPerQuantity;
    out.sobol.assign(static_cast<size_t>(G), {});
    long sobol_rows = 0;
    for (int q = 0; q < kQ; ++q) {
      QuantityStatistics& st = out.statistics[static_cast<size_t>(q)];
      const double n = per_q[q * kPerQuantity + 0];
      st.count = static_cast<long>(n);
      if (n > 0) {
        const double s1 = per_q[q * kPerQuantity + 1], s2 = per_q[q * kPerQuantity + 2];
        st.mean = pd.nominal[static_cast<size_t>(q)] + s1 / n;
        st.sd = n > 1 ? std::sqrt(std::max(0.0, (s2 - s1 * s1 / n) / (n - 1))) : 0.0;
        // The distribution for pictures.
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        auto extremes = [&](double v, std::uint64_t) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        };
        if (s.exact) {
          const ValueVector& v = values[static_cast<size_t>(p * kQ + q)];
          Extremes(v.data(), static_cast<long>(v.size()), &lo, &hi);
        } else {
          histograms[static_cast<size_t>(p * kQ + q)].ForEach(extremes);
        }
        st.histogram_lower = std::max(lo, st.mean - 4 * st.sd);
        st.histogram_upper = std::min(hi, st.mean + 4 * st.sd);
        st.histogram.assign(kUncertaintyHistogramBins, 0);
        const double width = (st.histogram_upper - st.histogram_lower) / kUncertaintyHistogramBins;
        auto bin = [&](double v, std::uint64_t count) {
          if (v < st.histogram_lower || v > st.histogram_upper) return;
          long k = width > 0 ? static_cast<long>((v - st.histogram_lower) / width) : 0;
          k = std::clamp<long>(k, 0, kUncertaintyHistogramBins - 1);
          st.histogram[static_cast<size_t>(k)] += static_cast<long>(count);
        };
        if (s.exact) {
          const ValueVector& v = values[static_cast<size_t>(p * kQ + q)];
          const double lower = st.histogram_lower, upper = st.histogram_upper;
          HistogramCounts(v.data(), static_cast<long>(v.size()), lower, upper, width,
                          st.histogram.data());
        } else {
          histograms[static_cast<size_t>(p * kQ + q)].ForEach(bin);
        }
        if (s.exact) {
          BucketPercentiles(values[static_cast<size_t>(p * kQ + q)], lo, hi, kPercentileLevels, 4,
                            st.percentiles.data());
        } else {
          for (int k = 0; k < 4; ++k) {
            st.percentiles[static_cast<size_t>(k)] = HistogramPercentile(
                histograms[static_cast<size_t>(p * kQ + q)], kPercentileLevels[k]);
          }
        }
      }
      const double ns = per_q[q * kPerQuantity + 3];
      if (q == 0) sobol_rows = static_cast<long>(ns);
      const double variance = st.sd * st.sd;
      for (int g = 0; g < G && UncertaintySobolQuantity(q); ++g) {
        SobolIndex& idx = out.sobol[static_cast<size_t>(g)][static_cast<size_t>(q)];
        if (ns > 0 && variance > 0) {
          idx.first = sob[(g * kQ + q) * 2 + 0] / ns / variance;
          idx.total = sob[(g * kQ + q) * 2 + 1] / ns / (2.0 * variance);
        }
      }
    }
    out.sobol_rows = sobol_rows;
    result.postures.push_back(std::move(out));
  }
  return result;
}

}  // namespace

UncertaintyResult RunUncertainty(const Model& model, const std::string& muscle,
                                 const Eigen::MatrixXd& postures, const UncertaintySpec& spec,
                                 const UncertaintyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  UncertaintyStudy study(model, muscle, postures, spec, options);
  // RunUncertaintyBlocks + FinishUncertainty without the partial's bytes in between: the records
  // added and the values concatenated in block order, as FinishUncertainty does (the same bits).
  const UncertaintyStudy::Impl& s = study.impl();
  BlockOutput output =
      RunUncertaintyBlocksOutput(study, 0, study.block_count(), options.threads, options.progress);
  const long n_blocks = study.block_count();
  const long P = s.postures.cols();
  const long RS = s.RecordSize();
  std::vector<double> sum(static_cast<size_t>(P * RS), 0.0);
  for (long k = 0; k < n_blocks; ++k) {
    for (long i = 0; i < P * RS; ++i)
      sum[static_cast<size_t>(i)] += output.records[static_cast<size_t>(k * P * RS + i)];
  }
  std::vector<ValueVector> values(s.exact ? static_cast<size_t>(P * kQ) : 0);
  for (size_t i = 0; i < values.size(); ++i) {
    size_t n = 0;
    for (const std::vector<ValueVector>& block : output.values) n += block[i].size();
    values[i].reserve(n);
    for (const std::vector<ValueVector>& block : output.values)
      values[i].insert(values[i].end(), block[i].begin(), block[i].end());
  }
  output.values.clear();
  UncertaintyResult result = Statistics(study, sum, values, output.histograms);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace isowrench
