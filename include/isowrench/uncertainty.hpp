#pragma once
/// @file
/// Monte Carlo uncertainty of the wrench (docs/uncertainty.md): uncertain inputs (stiffnesses,
/// joint angles, muscle force, transducer misalignment and calibration, or a fit's parameters
/// and covariance) are sampled, every sample is evaluated by the engine (engine.hpp), and per
/// posture the mean, sd and percentiles of every wrench component, the spread of the force
/// direction, the fraction of samples without equilibrium or outside the small-motion rule, and
/// each input's first-order (and total) Sobol index are reported.
///
/// Reproducibility: every random number is a function of (seed, sample index, design matrix,
/// dimension) only (Random123's Philox4x64-10, a counter-based generator), samples are
/// evaluated in fixed blocks of kUncertaintyBlockSamples, and the blocks' partial sums are added
/// in block order. So the result is the same to the last bit on 1, 2 or 4 threads and for any
/// split of the blocks into parts (RunUncertaintyBlocks + MergeUncertaintyPartials, the way
/// isowrench.study spreads a study over Dask workers).
///
/// Design (Saltelli 2010): two independent N x D matrices A and B of input draws and, for each
/// input group i, A_B^i (A with group i's columns from B). Moments and percentiles use the 2N
/// rows of A and B; first-order indices use Saltelli's 2010 estimator
///   S_i  = mean_j[ f(B)_j (f(A_B^i)_j - f(A)_j) ] / V,
/// total indices Jansen's 1999 estimator
///   ST_i = mean_j[ (f(A)_j - f(A_B^i)_j)^2 ] / (2 V),
/// V the variance over A and B. N (d + 2) evaluations for d groups; without Sobol indices, N.
///
/// How inputs reach the engine: stiffness draws become StiffnessSets, angle draws postures,
/// point draws path point offsets (SetPathPointOffsets), force factors scale W (W is linear in
/// tau, and tau in max_force), the activation scales W for the constant force model and is
/// evaluated by the engine for the others, and misalignment, sensor origin, calibration and
/// offset act on W afterwards (the reading). Only the public engine API is used, so force models
/// and muscle paths of later stages apply unchanged.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "isowrench/engine.hpp"
#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

/// Samples per block (rows of A): the unit of work, of partial results and of merging. Part of
/// the reproducibility contract: results are bit-identical for any thread count or partition
/// of the blocks, for this block size.
inline constexpr long kUncertaintyBlockSamples = 2048;

/// Distribution of one uncertain input (the parameters' meaning is per input kind: see
/// UncertainInput).
enum class InputDistribution {
  kNormal,      ///< mean + sd z
  kLogNormal,   ///< median * exp(sd z): sd is the sd of ln(value)
  kUniform,     ///< uniform on [lower, upper]
  kLogUniform,  ///< exp(uniform on [ln lower, ln upper])
};

/// "normal", "lognormal", "uniform", "loguniform".
const char* DistributionName(InputDistribution distribution);

/// One uncertain input, as a user names it. Names and what they perturb (units of sd, lower,
/// upper in brackets):
///  - transducer_stiffness:<dof> (dof x y z rx ry rz): S_t entry. lognormal: factor on the
///    model's value with median 1 (sd of ln); loguniform: the value itself [N/m, N·m/rad].
///  - base_stiffness: the base translation dofs' stiffness (one factor for all three);
///    joint_stiffness:<coordinate>: one S_p entry. As transducer_stiffness [N/m, N·m/rad].
///  - angle:<coordinate>: offset added to the coordinate, normal (mean 0) or uniform [deg; mm for
///    prismatic coordinates].
///  - max_force or max_force:<muscle> (the study's muscle): factor on max_force, normal (mean 1),
///    lognormal (median 1) or uniform [x].
///  - activation: the activation itself, normal (mean: the study's activation) or uniform [1].
///  - misalignment: transducer axes turned by the rotation vector r (transducer axes), each
///    component normal, mean 0; sd one value or three [deg]. The reading is R^T W, R = exp([r]x).
///  - gain:<axis> (fx fy fz mx my mz): diagonal of the calibration matrix, normal (mean 1),
///    lognormal (median 1) or uniform [x].
///  - crosstalk (all 30 terms) or crosstalk:<reading>_<source>: off-diagonal terms Ê of the
///    calibration, normal, mean 0 [1, normalised as the fit's: E = D Ê D^-1, D = diag(1, 1, 1,
///    L, L, L), L = Model::chain_length()]. Reading = (I + E) W (docs/identification.md).
///  - point:<muscle>:<index> (0 = origin, MuscleSpec::path order) of the study's muscle: the
///    path point moved in its link's frame, each axis normal (mean 0) or uniform offsets; sd
///    one value or three (x y z) [mm]; one Sobol group. point:<muscle>:<index>:<axis> (x, y, z):
///    one axis, its own group. Evaluated through SetPathPointOffsets (engine.hpp): the model is
///    not rebuilt; a wrapped muscle's wraps stay, its path points move.
///
/// A muscle with a force model (thelen2003, millard2012): max_force factors scale W (the force
/// is max_force times a function of the length and activation); the activation input is
/// evaluated by the engine at each sample's activation (F is not proportional to it), and a
/// sampled activation outside [0, 1] makes that sample invalid (a uniform beyond [0, 1] is
/// refused).
struct UncertainInput {
  std::string name;
  InputDistribution distribution = InputDistribution::kNormal;
  /// Standard deviation(s): one value, or three (per axis) for misalignment and point.
  std::vector<double> sd;
  double lower = 0.0;  ///< support of uniform / loguniform (lower < upper)
  double upper = 0.0;
};

/// A fit's parameters as a multivariate normal in the scale they were fitted in (log10 for
/// stiffnesses and factors, linear otherwise), read from `isowrench fit --json`.
struct FitUncertainty {
  std::string source;              ///< the JSON file
  std::string model;               ///< the fitted model's name
  std::vector<std::string> names;  ///< "effect.parameter", e.g. "base_isotropic.k_base"
  std::vector<bool> log10;         ///< fitted as log10(value)
  Eigen::VectorXd mean;            ///< estimates, fitted scale
  Eigen::MatrixXd covariance;      ///< fitted scale
  /// What was left out, one sentence each (e.g. a force_scale of another muscle).
  std::vector<std::string> notes;
};

/// Read `isowrench fit --json` output: the chosen effects' parameters, standard errors and the
/// joint correlation matrix. Supported effects: base_isotropic, base_per_axis,
/// transducer_soft:<dof>, transducer_anisotropy, force_scale:<muscle>, gain:<axis>, crosstalk,
/// misalignment, sensor_origin, sensor_offset, joint_offset:<coordinate>,
/// attachment:<muscle>:<i> (path point offsets, as point:<muscle>:<i>).
/// @throws Error naming the file for unreadable JSON, a fit of another model than `model`
///         ("... is a fit of model 'A', not of 'B'"), or an effect that cannot be sampled.
FitUncertainty ReadFitUncertainty(const std::string& path, const Model& model);

/// Everything that is uncertain.
struct UncertaintySpec {
  std::vector<UncertainInput> inputs;
  /// Optional: a fit's parameters (ReadFitUncertainty), sampled jointly. Correlated parameters
  /// form one Sobol group, "fit".
  bool has_fit = false;
  FitUncertainty fit;
};

/// Parse a spec file (JSON, docs/uncertainty.md "Spec file"):
///   {"inputs": [{"name": "transducer_stiffness:x", "distribution": "lognormal", "sd": 0.35},
///               {"name": "angle:hip_rz", "sd": 2}, {"name": "misalignment", "sd": [1, 1, 2]},
///               {"name": "base_stiffness", "distribution": "loguniform",
///                "lower": 1e4, "upper": 1e7}]}
/// `source` names the file in messages. Checked against the model by UncertaintyStudy.
/// @throws Error naming the file, the entry and the field (unknown field, missing sd, ...).
UncertaintySpec ParseUncertaintySpec(const std::string& json_text, const std::string& source);
/// One input from the command-line syntax NAME=DISTRIBUTION:PARAMETERS, the same inputs and
/// units as the spec file: "angle:hip_rz=normal:2", "misalignment=normal:1,1,2",
/// "transducer_stiffness:x=lognormal:0.35", "max_force=uniform:0.8:1.2",
/// "base_stiffness=loguniform:1e4:1e7". `option` names the option in messages.
/// @throws Error naming the text and the rule it breaks.
UncertainInput ParseUncertainInput(const std::string& text, const std::string& option = "--input");

/// The spec as JSON text that ParseUncertaintySpec reads back to an equal spec, the fit's
/// parameters, estimates and covariance included ("fit": {"source", "model", "names", "log10",
/// "mean", "covariance", "notes"}; numbers with 17 digits): how isowrench.study ships a study
/// to processes that cannot read the user's files.
std::string UncertaintySpecJson(const UncertaintySpec& spec);

/// ParseUncertaintySpec of a file's text. @throws Error naming the file when it cannot be read.
UncertaintySpec ReadUncertaintySpecFile(const std::string& path);

/// Options of an uncertainty study; each states what it controls.
struct UncertaintyOptions {
  long samples = 4096;     ///< N: rows of A (and of B); > 0
  std::uint64_t seed = 1;  ///< Philox key: the same seed gives the same numbers
  /// Compute Sobol indices (N (d + 2) evaluations); false: N evaluations, no indices.
  bool sobol = true;
  int threads = 2;          ///< worker threads (>= 1); never changes the result
  double activation = 1.0;  ///< nominal activation of the study's muscle
  StaticsOptions statics;   ///< small-motion rule and rank tolerance
  /// Percentiles are exact order statistics (linear interpolation, Hyndman-Fan type 7) while
  /// 2 N x postures x kUncertaintyQuantities <= exact_percentile_values (the values are kept in
  /// memory: 8 bytes each); beyond, a log-linear histogram (512 bins per octave, so a
  /// percentile is located to within 2^-10 ~ 0.1 % of its magnitude).
  double exact_percentile_values = 2e7;
  /// Called on the calling thread with (evaluations done, evaluations total); may be empty.
  std::function<void(long, long)> progress;
};

/// The quantities reported per sample: the reading in transducer axes (0-5: fx fy fz N, mx my
/// mz N·m), in world axes (6-11, R_W_T at the posture's nominal kinematics times the reading),
/// |f| (12, N), |m| (13, N·m) and the angle between f and the nominal f (14, rad).
inline constexpr int kUncertaintyQuantities = 15;

/// The quantities with Sobol indices: the reading in transducer axes, |f|, |m| and the direction
/// angle (world axes are a rotation of the reading: no indices of their own).
constexpr bool UncertaintySobolQuantity(int q) { return q < 6 || q >= 12; }

/// Name of quantity q: "fx", ..., "world_fx", ..., "force_magnitude", "moment_magnitude",
/// "direction_angle".
const char* UncertaintyQuantityName(int q);
/// Its unit: "N", "N·m" or "rad".
const char* UncertaintyQuantityUnit(int q);

/// Statistics of one quantity over the valid samples.
struct QuantityStatistics {
  double mean = 0.0, sd = 0.0;
  /// Percentiles 2.5, 50, 95, 97.5.
  std::array<double, 4> percentiles = {0.0, 0.0, 0.0, 0.0};
  long count = 0;  ///< valid samples the numbers use (0: the quantity is not defined)
  /// The distribution for pictures: kUncertaintyHistogramBins equal bins over
  /// [histogram_lower, histogram_upper] = [max(min, mean - 4 sd), min(max, mean + 4 sd)];
  /// values outside are not counted.
  double histogram_lower = 0.0, histogram_upper = 0.0;
  std::vector<long> histogram;
};

/// Bins of QuantityStatistics::histogram.
inline constexpr int kUncertaintyHistogramBins = 40;

/// First-order (Saltelli 2010) and total (Jansen 1999) Sobol index of one input group for one
/// quantity; 0 when the quantity has no variance.
struct SobolIndex {
  double first = 0.0;
  double total = 0.0;
};

/// Result at one posture.
struct PostureUncertainty {
  Eigen::VectorXd posture;  ///< nominal posture, rad / m (column order)
  /// The quantities at the inputs' central values (normal: mean, lognormal: median, uniform:
  /// midpoint, loguniform: geometric midpoint, fit: estimates).
  /// Meaningful only when nominal_defined() (0 otherwise; every output shows no number then).
  std::array<double, kUncertaintyQuantities> nominal{};
  StaticsStatus nominal_status = StaticsStatus::kInvalidInput;
  /// The central values give a wrench (kOk or kSelfMotionHeld): `nominal` holds it.
  bool nominal_defined() const {
    return nominal_status == StaticsStatus::kOk || nominal_status == StaticsStatus::kSelfMotionHeld;
  }
  std::array<QuantityStatistics, kUncertaintyQuantities> statistics;
  long samples = 0;              ///< rows of A and B evaluated (2N, N without Sobol)
  long valid = 0;                ///< with a wrench (kOk or kSelfMotionHeld) and finite
  long no_equilibrium = 0;       ///< kSelfMotion: excluded from every statistic
  long invalid = 0;              ///< kInvalidInput or a non-finite result: excluded
  long small_motion_failed = 0;  ///< valid but outside the small-motion rule (kept)
  /// Sobol indices per group (UncertaintyResult::groups) and quantity (0 for the world-axes
  /// quantities: UncertaintySobolQuantity).
  std::vector<std::array<SobolIndex, kUncertaintyQuantities>> sobol;
  long sobol_rows = 0;  ///< j with f(A), f(B) and every f(A_B^i) valid (the indices use these)
};

/// The whole study.
struct UncertaintyResult {
  std::string model;
  std::string muscle;
  std::vector<std::string> groups;  ///< Sobol input groups (input names; "fit")
  long samples = 0;                 ///< N
  long evaluations = 0;             ///< engine evaluations
  std::uint64_t seed = 0;
  bool sobol = true;
  bool exact_percentiles = true;  ///< false: log-linear histogram (UncertaintyOptions)
  std::string percentile_method;  ///< one sentence
  std::vector<PostureUncertainty> postures;
  std::vector<std::string> notes;
  double seconds = 0.0;  ///< wall time
};

/// A study ready to run (RunUncertainty makes one): the model with the spec's inputs resolved,
/// the postures and the design. Cheap to copy (shared state); thread-safe to run from several
/// threads.
class UncertaintyStudy {
 public:
  /// @throws Error for an unknown input name, coordinate, muscle, path point or axis (with the
  ///         closest name), a negative or non-finite sd, an empty support (lower >= upper, or
  ///         <= 0 for loguniform), an input the model cannot take (a released dof with a
  ///         lognormal, no base dofs, another muscle, two inputs moving the same point axis,
  ///         an activation outside [0, 1] for a force model), a posture of the wrong size,
  ///         samples <= 0.
  UncertaintyStudy(const Model& model, const std::string& muscle, const Eigen::MatrixXd& postures,
                   const UncertaintySpec& spec, const UncertaintyOptions& options);
  ~UncertaintyStudy();
  UncertaintyStudy(const UncertaintyStudy&);
  UncertaintyStudy& operator=(const UncertaintyStudy&);

  long block_count() const;       ///< ceil(N / kUncertaintyBlockSamples)
  long evaluation_count() const;  ///< engine evaluations of the whole study
  const std::vector<std::string>& groups() const;
  /// A 64-bit fingerprint of everything that defines the numbers (model, postures, spec,
  /// options but threads and progress): partials of different studies are refused.
  std::uint64_t fingerprint() const;
  const Model& model() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<Impl> impl_;
};

/// Partial results of blocks [first_block, last_block): per block and posture the counts and
/// shifted sums, and the percentile data. Serialisable (bytes) to cross process boundaries.
struct UncertaintyPartial {
  std::uint64_t fingerprint = 0;
  long first_block = 0;
  long last_block = 0;
  std::string data;  ///< opaque
  /// The partial as bytes (same machine architecture to read them back).
  std::string ToBytes() const;
  /// @throws Error for bytes that are not a partial.
  static UncertaintyPartial FromBytes(const std::string& bytes);
};

/// Run blocks [first_block, last_block) on `threads` threads.
/// @throws Error for a range outside [0, block_count()].
UncertaintyPartial RunUncertaintyBlocks(const UncertaintyStudy& study, long first_block,
                                        long last_block, int threads = 1,
                                        const std::function<void(long, long)>& progress = {});

/// The result from partials covering every block exactly once (any order, any split).
/// @throws Error naming the gap, overlap or foreign fingerprint.
UncertaintyResult FinishUncertainty(const UncertaintyStudy& study,
                                    const std::vector<UncertaintyPartial>& partials);

/// UncertaintyStudy + RunUncertaintyBlocks(all blocks, options.threads) + FinishUncertainty.
UncertaintyResult RunUncertainty(const Model& model, const std::string& muscle,
                                 const Eigen::MatrixXd& postures, const UncertaintySpec& spec,
                                 const UncertaintyOptions& options);

/// The result as JSON text (what `isowrench uncertainty --json` prints; docs/uncertainty.md).
std::string UncertaintyJson(const UncertaintyResult& result, const Model& model);

/// SVG: per posture the force and moment glyphs (include/isowrench/plots.hpp, world axes) of
/// the mean reading, with each component's 95 % range (2.5 to 97.5 %) as a pale band along its
/// coloured projection, the 95 % range of |f| and |m| as a grey band along the vector, and the
/// 95 % direction spread of the force (the 95th percentile of the angle to the nominal force)
/// as a wedge of that half-angle around the force, drawn in the picture plane.
std::string UncertaintyGlyphSvg(const UncertaintyResult& result, const Model& model);

/// A self-contained HTML report (the house style of the fit report): the inputs and the design,
/// per posture the glyphs, a table of every quantity's statistics, the distributions of the
/// force and moment components, |f| and the direction angle as histograms, and the Sobol
/// indices as bars.
std::string UncertaintyReportHtml(const UncertaintyResult& result, const Model& model,
                                  const UncertaintySpec& spec);

// ---- building blocks, public for tests and for lab tools ----

/// The standard normal quantile Phi^-1(p) for 0 < p < 1 (Wichura 1988, AS 241 PPND16: relative
/// accuracy about 1e-16).
double NormalQuantile(double p);

/// Four uniforms in (0, 1) (53 random bits each) for counter (a, b, c) under `seed`: Philox4x64-10
/// (Random123). The same arguments always give the same numbers.
std::array<double, 4> PhiloxUniforms(std::uint64_t seed, std::uint64_t a, std::uint64_t b,
                                     std::uint64_t c);

}  // namespace isowrench
