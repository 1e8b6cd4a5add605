#pragma once
/// @file
/// Streaming access to trial CSV files (format in docs/identification.md), beside TrialReader,
/// ReadTrialsCsv and WriteTrialsCsv of isowrench/identification.hpp.
///
/// Reading follows RFC 4180: comma separators (or the TrialSheetOptions delimiter), fields
/// optionally in double quotes (a quote inside a quoted field is doubled; quoted fields may hold
/// separators and line breaks), CRLF or LF line ends, and a UTF-8 byte-order mark before the
/// header is skipped (spreadsheets and pandas write it). A file with ';' separators or decimal
/// commas read without declaring them is refused with a message saying how to declare them.
/// Measured values are range-checked (|force| and |moment| <= kMaxMeasuredWrench, activation in [0,
/// 1]); a missing limb joint column and angles beyond a full turn warn through isowrench::Warn.
/// Memory does not grow with the number of rows; one record is limited to kMaxCsvRecordBytes.

#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "isowrench/identification.hpp"

namespace isowrench {

/// Largest CSV record (one row, quoted line breaks included) the reader accepts, bytes.
constexpr size_t kMaxCsvRecordBytes = size_t(1) << 20;

/// What kind of sheet TrialReader reads, and how it is laid out. The CLI's options and Python's
/// keywords set these fields (docs/identification.md "Trial CSV").
struct TrialSheetOptions {
  /// Field separator: ',' (default), ';' (spreadsheets in locales with decimal commas), '\t'
  /// or '|'.
  char delimiter = ',';
  /// Numbers written with a decimal comma ("1,5" is 1.5); needs a delimiter other than ','.
  bool decimal_comma = false;
  /// Columns not to read, by name as written or without its unit ("trial", "date",
  /// "comment"). Other columns isowrench does not know are ignored too, with one warning
  /// naming them (and the closest known name).
  std::vector<std::string> ignore_columns;
  /// Physical lines to skip before the header (an instrument's preamble), >= 0.
  int skip_rows = 0;
  /// A posture sheet: the trials to record or simulate (isowrench design -o writes one;
  /// simulate --postures reads one). The measured wrench columns (fx ... mz, sd_*) are not
  /// required and are not read when present (design's sheet has them empty, for the lab to
  /// fill in); neither is `muscle` (Trial::muscle empty) nor `activation` (Trial::activation
  /// NaN: "not given"), and empty cells mean "not given" (a coordinate at its nominal value).
  bool postures_only = false;
};

// Units in the header are read and converted: "name (unit)" or "name [unit]", or a units row
// right under the header (every cell a unit or empty). Joint columns: deg (default) or rad,
// mm (default), cm or m; forces N (default), mN, kN; moments N·m (default; also written N.m,
// Nm, N m), N·mm, N·cm, mN·m, kN·m; activation 1 or %. This is what isowrench writes itself
// (`sweep`: "knee_rz (deg)", "fx (N)", "mx (N·m)").

/// The warning for angles that look recorded in radians and read as degrees, or "": every
/// revolute column of `largest` (coordinate index, largest |value| read, rad) stays within
/// kRadianSlipDegrees of 0 while the model's nominal posture has a column beyond
/// kRadianSlipNominalDegrees. TrialReader issues it (Warn) at the end of a file.
std::string RadianSlipWarning(const Model& model,
                              const std::vector<std::pair<int, double>>& largest);

/// Radian values read as degrees stay within 2 pi "degrees" of 0.
constexpr double kRadianSlipDegrees = 6.3;
/// ... while the model's posture has an angle at least this far from 0 (degrees).
constexpr double kRadianSlipNominalDegrees = 20.0;

/// A unit or sign slip: the least-squares factor of measured on predicted within this
/// fraction of the slip's factor (-1, 1000, -1000, 0.001) ...
constexpr double kSlipFactorTolerance = 0.1;
/// ... leaving at most this fraction of the measured sum of squares unexplained, on all three
/// forces or all three moments (a slip is the file's, not one axis's).
constexpr double kSlipUnexplainedFraction = 0.1;

/// The likely unit or sign slips behind measured data, one sentence each (empty when none):
/// angles recorded in radians (RadianSlipWarning over the coordinates the trials set), and
/// forces or moments whose measured values are -1 x ("sign convention?"), 1000 x ("moments in
/// N·mm?", "forces in mN?"), -1000 x or 0.001 x the model's prediction on all three axes
/// (kSlipFactorTolerance, kSlipUnexplainedFraction).
/// `predicted`: the nominal model's prediction of each trial (N, N·m). The fit's verdict
/// appends them.
std::vector<std::string> UnitSlips(const Model& nominal, const std::vector<Trial>& trials,
                                   const std::vector<Vector6d>& predicted);

/// ReadTrialsCsv for a sheet laid out as `sheet` says. @throws Error as TrialReader.
std::vector<Trial> ReadTrialsCsv(const Model& model, const std::string& path,
                                 const TrialSheetOptions& sheet);

/// Progress of a long read: rows so far and the fraction of the file's bytes consumed (0..1,
/// or -1 when the size is unknown).
using TrialProgress = std::function<void(long rows, double fraction)>;

/// Stream every trial of a CSV file through `on_trial`, one at a time (bounded memory).
/// `progress`, when set, is called about every `progress_every` rows and once at the end.
/// @returns the number of trials. @throws Error as TrialReader, or if the file cannot be
///          opened or holds no trial.
long ForEachTrial(const Model& model, const std::string& path,
                  const std::function<void(const Trial&)>& on_trial,
                  const TrialProgress& progress = {}, long progress_every = 100000);

/// ForEachTrial for a sheet laid out as `sheet` says.
long ForEachTrial(const Model& model, const std::string& path, const TrialSheetOptions& sheet,
                  const std::function<void(const Trial&)>& on_trial,
                  const TrialProgress& progress = {}, long progress_every = 100000);

/// A progress callback that rewrites one line on stderr ("reading data.csv: 300000 rows, 42%")
/// when stderr is a terminal (or always with `force`), and prints nothing otherwise.
TrialProgress TerminalProgress(const std::string& what, bool force = false);

/// The trials SimulateTrials returns (same options, same seed, same values), generated and
/// handed to `on_trial` `chunk` at a time: memory does not grow with options.postures.
/// `progress`, when set, is called after each chunk. @throws Error as SimulateTrials.
void ForEachSimulatedTrial(const Model& nominal, const AugmentedModel& truth,
                           const SimulationOptions& options,
                           const std::function<void(const Trial&)>& on_trial,
                           const TrialProgress& progress = {}, int chunk = 4096);

/// FitEffects on a trial CSV file in memory that does not grow with its number of rows. The
/// first pass reads and checks every row and keeps a uniform random sample of
/// options.max_fit_trials of them (TrialReservoir, options.sample_seed; all rows when there are
/// no more, or when max_fit_trials is 0); the sample is fitted (FitEffects); when rows were left
/// out, a second pass predicts every row with the nominal and the augmented model, 4096 rows at a
/// time, for FitReport::before / after and beyond_threshold_count. With no more rows than
/// max_fit_trials the report equals FitEffects(nominal, ReadTrialsCsv(nominal, path), options)
/// exactly (source and seconds aside). `read_progress` and `check_progress` report the two passes
/// as ForEachTrial does; `fitted`, when given, receives the fitted trials (the order of
/// FitReport::trials, for WriteFitReportHtml).
/// @throws Error as ForEachTrial and FitEffects, or when the file's row count changes between
///         the passes.
FitReport FitEffectsCsv(const Model& nominal, const std::string& path,
                        const FitOptions& options = {}, const TrialProgress& read_progress = {},
                        const TrialProgress& check_progress = {},
                        std::vector<Trial>* fitted = nullptr);

/// FitEffectsCsv on a sheet laid out as `sheet` says (delimiter, decimal comma, units, ignored
/// columns, skipped rows).
FitReport FitEffectsCsv(const Model& nominal, const std::string& path,
                        const TrialSheetOptions& sheet, const FitOptions& options = {},
                        const TrialProgress& read_progress = {},
                        const TrialProgress& check_progress = {},
                        std::vector<Trial>* fitted = nullptr);

/// Streaming writer of the CSV format TrialReader reads: the header on construction, then one
/// row per Write (bounded memory, for simulations of any size).
class TrialCsvWriter {
 public:
  /// `with_sd`: write the sd_* columns (every trial then needs has_sd).
  TrialCsvWriter(const Model& model, std::ostream& out, bool with_sd);
  ~TrialCsvWriter();
  TrialCsvWriter(const TrialCsvWriter&) = delete;
  TrialCsvWriter& operator=(const TrialCsvWriter&) = delete;
  /// Write one trial (joint values in degrees / mm, %.10g). @throws Error for a non-finite value.
  void Write(const Trial& trial);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace isowrench
