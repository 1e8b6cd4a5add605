#pragma once
/// @file
/// Streaming access to trial CSV files (format in docs/identification.md), beside TrialReader,
/// ReadTrialsCsv and WriteTrialsCsv of isowrench/identification.hpp.
///
/// Reading follows RFC 4180: comma separators, fields optionally in double quotes (a quote
/// inside a quoted field is doubled; quoted fields may hold commas and line breaks), CRLF or LF
/// line ends, and a UTF-8 byte-order mark before the header is skipped (spreadsheets and pandas
/// write it). Files that use ';' separators or decimal commas are refused with a message saying
/// so. Measured values are range-checked (|force| and |moment| <= kMaxMeasuredWrench,
/// activation in [0, 1]); a missing limb joint column and angles beyond a full turn warn through
/// isowrench::Warn. Memory does not grow with the number of rows; one record is limited to
/// kMaxCsvRecordBytes.

#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "isowrench/identification.hpp"

namespace isowrench {

/// Largest CSV record (one row, quoted line breaks included) the reader accepts, bytes.
constexpr size_t kMaxCsvRecordBytes = size_t(1) << 20;

/// What kind of sheet TrialReader reads, and how it is laid out. The CLI's options and Python's
/// keywords set these fields (docs/identification.md "Trial CSV").
struct TrialSheetOptions {
  /// A posture sheet: the trials to record or simulate (isowrench design -o writes one;
  /// simulate --postures reads one). The measured wrench columns (fx ... mz, sd_*) are not
  /// required and are not read when present (design's sheet has them empty, for the lab to
  /// fill in); neither is `muscle` (Trial::muscle empty) nor `activation` (Trial::activation
  /// NaN: "not given"), and empty cells mean "not given" (a coordinate at its nominal value).
  bool postures_only = false;
};

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
