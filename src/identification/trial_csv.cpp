// Measured-wrench CSV: a streaming RFC 4180 reader (one record in memory at a time) and writers.
// Format: docs/identification.md. No CSV library is used: Debian's libcsv (C, last release
// 2013) and fast-cpp-csv-parser (no quoted line breaks, fixed column count at compile time) do
// not fit; the record reader below is ~100 lines and fuzzed (fuzz/trial_csv_fuzzer.cpp).

#include "isowrench/trial_csv.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "isowrench/posture.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

const char* kWrenchColumns[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
const char* kSdColumns[6] = {"sd_fx", "sd_fy", "sd_fz", "sd_mx", "sd_my", "sd_mz"};

/// RFC 4180 records from a stream: quoted fields ("" is a quote; commas and line breaks
/// allowed inside), CRLF/LF/CR line ends, a leading UTF-8 BOM skipped. Unquoted fields are
/// trimmed of blanks. Lines that are empty or start with '#' are skipped.
class CsvRecords {
 public:
  CsvRecords(std::istream& in, const std::string& source) : buf_(in.rdbuf()), source_(source) {
    if (buf_ && buf_->sgetc() == 0xEF) {  // UTF-8 byte-order mark EF BB BF
      buf_->sbumpc();
      if (buf_->sbumpc() != 0xBB || buf_->sbumpc() != 0xBF) {
        throw Error(source_ + ":1: the file starts with a broken byte-order mark (not UTF-8 text)");
      }
    }
  }

  /// Next record; false at end of input. `start_line` is the record's first line.
  bool Next(std::vector<std::string>* fields, long* start_line) {
    while (true) {
      fields->clear();
      if (!buf_ || buf_->sgetc() == EOF) return false;
      *start_line = line_;
      int c = buf_->sgetc();
      if (c == '#') {  // comment line
        SkipLine();
        continue;
      }
      if (c == '\n' || c == '\r') {  // blank line
        EndOfLine();
        continue;
      }
      ReadRecord(fields);
      if (fields->size() == 1 && !quoted_any_) {  // blank, or an indented comment
        std::string only = util::Trim((*fields)[0]);
        if (only.empty() || only[0] == '#') continue;
      }
      return true;
    }
  }

  long line() const { return line_; }

 private:
  void EndOfLine() {
    int c = buf_->sbumpc();
    if (c == '\r' && buf_->sgetc() == '\n') buf_->sbumpc();
    ++line_;
  }

  void SkipLine() {
    int c;
    while ((c = buf_->sgetc()) != EOF && c != '\n' && c != '\r') buf_->sbumpc();
    if (c != EOF) EndOfLine();
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(source_ + ":" + std::to_string(line_) + ": " + what);
  }

  void Add(std::string* field, char c) {
    if (++record_bytes_ > kMaxCsvRecordBytes) {
      Fail("a record longer than " + std::to_string(kMaxCsvRecordBytes) +
           " bytes (an unclosed quote, or not a trial CSV file)");
    }
    field->push_back(c);
  }

  void ReadRecord(std::vector<std::string>* fields) {
    record_bytes_ = 0;
    quoted_any_ = false;
    while (true) {
      std::string field;
      bool quoted = false;
      // leading blanks of an unquoted field, or before an opening quote
      int c;
      while ((c = buf_->sgetc()) == ' ' || c == '\t')
        Add(&field, static_cast<char>(buf_->sbumpc()));
      if (c == '"') {
        quoted = quoted_any_ = true;
        field.clear();
        long opened = line_;
        buf_->sbumpc();
        while (true) {
          c = buf_->sbumpc();
          if (c == EOF) {
            throw Error(source_ + ":" + std::to_string(opened) +
                        ": a quoted field opened here never closes");
          }
          if (c == '"') {
            if (buf_->sgetc() == '"') {
              buf_->sbumpc();
              Add(&field, '"');
              continue;
            }
            break;
          }
          if (c == '\n' || (c == '\r' && buf_->sgetc() != '\n')) ++line_;
          Add(&field, static_cast<char>(c));
        }
        while ((c = buf_->sgetc()) == ' ' || c == '\t') buf_->sbumpc();
        if (c != ',' && c != '\n' && c != '\r' && c != EOF) {
          Fail("unexpected '" + std::string(1, static_cast<char>(c)) +
               "' after a closing quote (RFC 4180: a quote inside a quoted field is written \"\")");
        }
      } else {
        while ((c = buf_->sgetc()) != EOF && c != ',' && c != '\n' && c != '\r') {
          Add(&field, static_cast<char>(buf_->sbumpc()));
        }
      }
      fields->push_back(quoted ? field : util::Trim(field));
      c = buf_->sgetc();
      if (c == ',') {
        buf_->sbumpc();
        continue;
      }
      if (c != EOF) EndOfLine();
      return;
    }
  }

  std::streambuf* buf_;
  const std::string& source_;
  long line_ = 1;
  size_t record_bytes_ = 0;
  bool quoted_any_ = false;
};

/// "1,5" or "-0,25": a number written with a decimal comma.
bool LooksLikeDecimalComma(const std::string& text) {
  size_t comma = text.find(',');
  if (comma == std::string::npos || text.find(',', comma + 1) != std::string::npos) return false;
  std::string dotted = text;
  dotted[comma] = '.';
  double v;
  return util::ParseDouble(dotted, &v);
}

const char* kSeparatorAdvice =
    "isowrench reads comma-separated values with '.' as the decimal point (RFC 4180): export "
    "as 'CSV (comma delimited)' or with pandas' to_csv() defaults";

}  // namespace

struct TrialReader::Impl {
  const Model* model = nullptr;
  TrialSheetOptions sheet;
  std::istream* input = nullptr;
  std::string source;
  std::unique_ptr<CsvRecords> records;
  long line_number = 0;
  std::vector<std::string> columns;
  std::vector<std::string> fields;  ///< the current record (reused: no allocation per row)
  std::vector<int> joint_column;    ///< per file column: model joint index or -1
  std::vector<bool> warned;         ///< per file column: a range warning was issued
  int muscle_column = -1;
  int activation_column = -1;
  int wrench_column[6] = {-1, -1, -1, -1, -1, -1};
  int sd_column[6] = {-1, -1, -1, -1, -1, -1};
  bool has_sd = false;
  Eigen::VectorXd nominal;
  double limb_length = 0;  ///< LimbLength of the model (plausibility of prismatic columns)
  std::shared_ptr<const std::vector<std::string>> joint_names;

  std::string Where(int column) const {
    std::string s = source + ":" + std::to_string(line_number);
    if (column >= 0) s += ", column " + std::to_string(column + 1) + " '" + columns[column] + "'";
    return s;
  }
};

TrialReader::TrialReader(const Model& model, std::istream& input, std::string source_name)
    : TrialReader(model, input, std::move(source_name), TrialSheetOptions()) {}

TrialReader::TrialReader(const Model& model, std::istream& input, std::string source_name,
                         const TrialSheetOptions& sheet)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.model = &model;
  m.sheet = sheet;
  m.input = &input;
  m.source = std::move(source_name);
  m.nominal = model.nominal_posture();
  m.limb_length = LimbLength(model.description());
  m.joint_names = std::make_shared<const std::vector<std::string>>(model.joint_names());
  m.records = std::make_unique<CsvRecords>(input, m.source);
  if (!m.records->Next(&m.columns, &m.line_number)) {
    throw Error(m.source +
                ": no header line (expected column names such as muscle,fx,fy,fz,mx,my,mz)");
  }
  for (std::string& name : m.columns) name = util::Trim(name);
  if (m.columns.size() == 1) {
    for (char separator : {';', '\t', '|'}) {
      if (m.columns[0].find(separator) != std::string::npos) {
        std::string shown =
            separator == '\t' ? std::string("a tab") : "'" + std::string(1, separator) + "'";
        throw Error(m.Where(-1) + ": the header '" + m.columns[0] + "' uses " + shown +
                    " as the separator (a spreadsheet export in a locale with decimal commas?); " +
                    kSeparatorAdvice);
      }
    }
  }
  m.joint_column.assign(m.columns.size(), -1);
  m.warned.assign(m.columns.size(), false);
  std::map<std::string, int> seen;
  const std::vector<std::string>& joints = model.joint_names();
  std::vector<bool> joint_present(joints.size(), false);
  for (size_t c = 0; c < m.columns.size(); ++c) {
    const std::string& name = m.columns[c];
    int col = static_cast<int>(c);
    if (name.empty())
      throw Error(m.Where(-1) + ", column " + std::to_string(c + 1) + ": empty column name");
    if (seen.count(name)) {
      throw Error(m.Where(col) + ": duplicate column (also column " +
                  std::to_string(seen[name] + 1) + ")");
    }
    seen[name] = col;
    if (name == "muscle") {
      m.muscle_column = col;
      continue;
    }
    if (name == "activation") {
      m.activation_column = col;
      continue;
    }
    bool matched = false;
    for (int i = 0; i < 6; ++i) {
      if (name == kWrenchColumns[i]) {
        m.wrench_column[i] = col;
        matched = true;
      }
      if (name == kSdColumns[i]) {
        m.sd_column[i] = col;
        matched = true;
      }
    }
    if (matched) continue;
    for (size_t j = 0; j < joints.size(); ++j) {
      if (joints[j] == name) {
        m.joint_column[c] = static_cast<int>(j);
        joint_present[j] = true;
        matched = true;
      }
    }
    if (!matched) {
      std::vector<std::string> known = joints;
      for (const char* k : {"muscle", "activation"}) known.push_back(k);
      for (int i = 0; i < 6; ++i) {
        known.push_back(kWrenchColumns[i]);
        known.push_back(kSdColumns[i]);
      }
      throw Error(m.Where(col) + ": unknown column" + DidYouMean(name, known) +
                  ": not a joint of model '" + model.name() + "' (" + util::Join(joints, ", ") +
                  ") nor one of muscle, activation, fx fy fz mx my mz, sd_fx ... sd_mz");
    }
  }
  if (m.sheet.postures_only) {
    // A posture sheet: measured columns are the lab's to fill in, not read here.
    for (int i = 0; i < 6; ++i) m.wrench_column[i] = m.sd_column[i] = -1;
  } else {
    std::vector<std::string> missing;
    if (m.muscle_column < 0) missing.push_back("muscle");
    int wrench_count = 0;
    for (int i = 0; i < 6; ++i) {
      wrench_count += m.wrench_column[i] >= 0;
      if (m.wrench_column[i] < 0) missing.push_back(kWrenchColumns[i]);
    }
    int sd_count = 0;
    for (int i = 0; i < 6; ++i) sd_count += m.sd_column[i] >= 0;
    if (sd_count != 0 && sd_count != 6) {
      for (int i = 0; i < 6; ++i) {
        if (m.sd_column[i] < 0) missing.push_back(kSdColumns[i]);
      }
    }
    if (wrench_count == 0 && m.muscle_column >= 0) {
      throw Error(m.Where(-1) +
                  ": no measured wrench columns (fx fy fz mx my mz): this is a posture sheet, "
                  "the trials to record (isowrench design -o writes one). Record each row and "
                  "add the measured fx ... mz (N, N·m), or simulate it: isowrench simulate "
                  "<urdf> --postures " +
                  m.source + " -o data.csv");
    }
    if (!missing.empty()) {
      throw Error(m.Where(-1) + ": header lacks required column(s) " + util::Join(missing, ", ") +
                  " (sd columns: all six or none)");
    }
    m.has_sd = sd_count == 6;
  }
  // A limb joint without a column silently takes the nominal posture: say so. Base, extra and
  // release dofs are compliance dofs, not measured angles: their absence is normal.
  for (size_t j = 0; j < joints.size(); ++j) {
    const JointSpec& spec = model.joint(static_cast<int>(j));
    if (joint_present[j] || spec.role != JointRole::kLimb) continue;
    bool revolute = spec.type == JointType::kRevolute;
    Warn(m.Where(-1) + ": no column '" + joints[j] + "': every trial uses the model's nominal " +
         joints[j] + " = " +
         util::FormatNumber(JointValueToUserUnits(spec.type, m.nominal[static_cast<int>(j)])) +
         (revolute ? " deg" : " mm"));
  }
}

TrialReader::~TrialReader() = default;

const std::vector<std::string>& TrialReader::columns() const { return impl_->columns; }

bool TrialReader::Next(Trial* trial) {
  Impl& m = *impl_;
  std::vector<std::string>& fields = m.fields;
  if (!m.records->Next(&fields, &m.line_number)) {
    if (m.input->bad())
      throw Error(m.source + ": read error after line " + std::to_string(m.records->line()));
    return false;
  }
  if (fields.size() != m.columns.size()) {
    std::string hint;
    if (fields.size() > m.columns.size()) {
      hint = " (decimal commas? '1,5' must be written 1.5: ";
      hint += kSeparatorAdvice;
      hint += ")";
    } else if (fields.size() == 1 && fields[0].find(';') != std::string::npos) {
      hint = std::string(" (';' separators? ") + kSeparatorAdvice + ")";
    }
    throw Error(m.Where(-1) + ": expected " + std::to_string(m.columns.size()) +
                " fields (as the header), found " + std::to_string(fields.size()) + hint);
  }
  auto number = [&](int c) {
    double v = 0.0;
    if (!util::ParseDouble(fields[c], &v)) {
      if (LooksLikeDecimalComma(fields[c])) {
        throw Error(m.Where(c) + ": '" + fields[c] + "' uses a decimal comma; " + kSeparatorAdvice);
      }
      throw Error(m.Where(c) + ": '" + fields[c] + "' is not a number");
    }
    if (!std::isfinite(v)) throw Error(m.Where(c) + ": value '" + fields[c] + "' is not finite");
    return v;
  };
  Trial t;
  t.line = m.line_number;
  t.joint_names = m.joint_names;
  t.q = m.nominal;
  for (size_t c = 0; c < fields.size(); ++c) {
    int j = m.joint_column[c];
    if (j < 0) continue;
    if (m.sheet.postures_only && fields[c].empty()) continue;  // the nominal value
    int col = static_cast<int>(c);
    double v = number(col);
    JointType type = m.model->joint(j).type;
    bool revolute = type == JointType::kRevolute;
    // Values that cannot be a joint position at all are errors; implausible ones (outside the
    // joint's limits, beyond a full turn, a translation longer than the limb) warn, once per
    // column, from the one place every reader asks (CoordinateValueWarning).
    double full = revolute ? 360.0 : 2000.0;
    if (std::abs(v) > 1e3 * full) {
      throw Error(m.Where(col) + ": " + fields[c] + (revolute ? " deg" : " mm") +
                  " cannot be a joint position (|value| > " + util::FormatNumber(1e3 * full) + ")");
    }
    t.q[j] = JointValueFromUserUnits(type, v);
    if (!m.warned[c]) {
      const std::string w =
          CoordinateValueWarning(m.model->coordinate(j), t.q[j], m.limb_length, m.Where(col),
                                 /*typed_in_user_units=*/true);
      if (!w.empty()) {
        m.warned[c] = true;
        Warn(w + " (later rows of this column are not reported)");
      }
    }
  }
  t.muscle = m.muscle_column >= 0 ? fields[m.muscle_column] : std::string();
  if (!(m.sheet.postures_only && t.muscle.empty())) {
    try {
      m.model->MuscleIndex(t.muscle);
    } catch (const Error& e) {
      throw Error(m.Where(m.muscle_column) + ": " + e.what());
    }
  }
  if (m.sheet.postures_only && (m.activation_column < 0 || fields[m.activation_column].empty())) {
    t.activation = std::numeric_limits<double>::quiet_NaN();  // not given
  } else if (m.activation_column >= 0) {
    t.activation = number(m.activation_column);
    if (!(t.activation >= 0 && t.activation <= 1)) {
      throw Error(m.Where(m.activation_column) + ": activation " + fields[m.activation_column] +
                  " must be in [0, 1] (a fraction of the muscle's max_force)");
    }
  }
  for (int i = 0; i < 6 && !m.sheet.postures_only; ++i) {
    int c = m.wrench_column[i];
    if (fields[c].empty()) {
      throw Error(m.Where(c) + ": empty: this row's trial has no measured " + kWrenchColumns[i] +
                  " (a posture sheet lists the trials to record: fill in every measured "
                  "column, or delete the rows not recorded)");
    }
    t.wrench[i] = number(c);
    if (std::abs(t.wrench[i]) > kMaxMeasuredWrench) {
      throw Error(m.Where(c) + ": " + fields[c] +
                  (i < 3 ? " N cannot be a measured force" : " N·m cannot be a measured moment") +
                  " (|value| > " + util::FormatNumber(kMaxMeasuredWrench) + ")");
    }
  }
  t.has_sd = m.has_sd;
  if (m.has_sd) {
    for (int i = 0; i < 6; ++i) {
      int c = m.sd_column[i];
      t.sd[i] = number(c);
      if (!(t.sd[i] > 0))
        throw Error(m.Where(c) + ": standard deviation " + fields[c] + " must be > 0");
      if (t.sd[i] > kMaxMeasuredWrench) {
        throw Error(m.Where(c) + ": standard deviation " + fields[c] + " is not plausible (> " +
                    util::FormatNumber(kMaxMeasuredWrench) + ")");
      }
    }
  }
  *trial = std::move(t);
  return true;
}

TrialReservoir::TrialReservoir(long capacity, unsigned long long seed)
    : capacity_(capacity), state_(seed) {
  if (capacity < 0) {
    throw Error("trial sample: the capacity must be >= 0 (0 = keep every trial), got " +
                std::to_string(capacity));
  }
}

void TrialReservoir::Add(const Trial& trial) {
  const long index = seen_++;
  if (capacity_ == 0 || index < capacity_) {
    kept_.push_back(trial);
    order_.push_back(index);
    return;
  }
  // Algorithm R: trial `index` (0-based) replaces a uniformly chosen slot with probability
  // capacity / (index + 1). j uniform in [0, index] from 53 random bits (bias < index / 2^53).
  ident::Random random(state_);  // splitmix64: the state advances by a constant per number
  const double u = random.Uniform();
  state_ += 0x9E3779B97F4A7C15ULL;
  const long j = std::min(index, static_cast<long>(u * static_cast<double>(index + 1)));
  if (j < capacity_) {
    kept_[j] = trial;
    order_[j] = index;
  }
}

std::vector<Trial> TrialReservoir::Take() {
  std::vector<size_t> by_order(kept_.size());
  for (size_t i = 0; i < by_order.size(); ++i) by_order[i] = i;
  std::sort(by_order.begin(), by_order.end(),
            [this](size_t a, size_t b) { return order_[a] < order_[b]; });
  std::vector<Trial> out;
  out.reserve(kept_.size());
  for (size_t i : by_order) out.push_back(std::move(kept_[i]));
  kept_.clear();
  order_.clear();
  return out;
}

std::vector<Trial> ReadTrialsCsv(const Model& model, const std::string& path) {
  return ReadTrialsCsv(model, path, TrialSheetOptions());
}

std::vector<Trial> ReadTrialsCsv(const Model& model, const std::string& path,
                                 const TrialSheetOptions& sheet) {
  std::vector<Trial> trials;
  ForEachTrial(model, path, sheet, [&](const Trial& t) { trials.push_back(t); });
  return trials;
}

long ForEachTrial(const Model& model, const std::string& path,
                  const std::function<void(const Trial&)>& on_trial, const TrialProgress& progress,
                  long progress_every) {
  return ForEachTrial(model, path, TrialSheetOptions(), on_trial, progress, progress_every);
}

long ForEachTrial(const Model& model, const std::string& path, const TrialSheetOptions& sheet,
                  const std::function<void(const Trial&)>& on_trial, const TrialProgress& progress,
                  long progress_every) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error("cannot open data file '" + path + "'");
  double size = -1;
  if (progress) {
    file.seekg(0, std::ios::end);
    std::streamoff end = file.tellg();
    file.seekg(0, std::ios::beg);
    if (end > 0) size = static_cast<double>(end);
  }
  TrialReader reader(model, file, path, sheet);
  Trial t;
  long rows = 0;
  if (progress_every < 1) progress_every = 1;
  while (reader.Next(&t)) {
    on_trial(t);
    ++rows;
    if (progress && rows % progress_every == 0) {
      std::streamoff at = file.tellg();
      progress(rows, size > 0 && at >= 0 ? static_cast<double>(at) / size : -1.0);
    }
  }
  if (rows == 0) {
    throw Error(path + (sheet.postures_only ? ": no postures (only a header)"
                                            : ": no trials (only a header)"));
  }
  if (progress) progress(rows, 1.0);
  return rows;
}

TrialProgress TerminalProgress(const std::string& what, bool force) {
  if (!force && !isatty(fileno(stderr))) return {};
  // One line per whole percent (a terminal rewrites it in place with '\r').
  auto last = std::make_shared<int>(-1);
  return [what, last](long rows, double fraction) {
    const int percent = fraction >= 0 ? static_cast<int>(fraction * 100 + 0.5) : -1;
    if (percent >= 0 && percent == *last && fraction < 1) return;
    *last = percent;
    std::cerr << "\r" << what << ": " << rows << " rows";
    if (fraction >= 0) std::cerr << ", " << percent << "%";
    std::cerr << (fraction >= 1 ? "\n" : "") << std::flush;
  };
}

struct TrialCsvWriter::Impl {
  const Model* model;
  std::ostream* out;
  bool sd;
};

TrialCsvWriter::TrialCsvWriter(const Model& model, std::ostream& out, bool with_sd)
    : impl_(std::make_unique<Impl>(Impl{&model, &out, with_sd})) {
  const std::vector<std::string>& joints = model.joint_names();
  out << "# isowrench measured wrenches; joints in degrees (mm for prismatic), forces N, moments "
         "N·m, "
         "transducer axes\n";
  for (size_t j = 0; j < joints.size(); ++j) out << joints[j] << ",";
  out << "muscle,activation,fx,fy,fz,mx,my,mz";
  if (with_sd) out << ",sd_fx,sd_fy,sd_fz,sd_mx,sd_my,sd_mz";
  out << "\n";
}

TrialCsvWriter::~TrialCsvWriter() = default;

void TrialCsvWriter::Write(const Trial& t) {
  const Model& model = *impl_->model;
  std::ostream& out = *impl_->out;
  std::vector<int> map =
      t.joint_names ? ident::JointMap(model, *t.joint_names) : std::vector<int>();
  Eigen::VectorXd q = model.nominal_posture();
  if (t.joint_names) {
    for (size_t i = 0; i < map.size(); ++i) {
      if (map[i] >= 0) q[map[i]] = t.q[i];
    }
  } else if (t.q.size() == q.size()) {
    q = t.q;
  }
  if (!q.allFinite() || !t.wrench.allFinite() || !std::isfinite(t.activation) ||
      (impl_->sd && !t.sd.allFinite())) {
    throw Error("trial CSV: a trial of muscle '" + t.muscle +
                "' holds a non-finite value; nothing written for it");
  }
  for (int j = 0; j < q.size(); ++j) {
    double v = JointValueToUserUnits(model.joint(j).type, q[j]);
    out << util::FormatNumber(v, 10) << ",";
  }
  out << t.muscle << "," << util::FormatNumber(t.activation, 10);
  for (int i = 0; i < 6; ++i) out << "," << util::FormatNumber(t.wrench[i], 10);
  if (impl_->sd) {
    for (int i = 0; i < 6; ++i) out << "," << util::FormatNumber(t.sd[i], 10);
  }
  out << "\n";
}

void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, std::ostream& out) {
  TrialCsvWriter writer(model, out, !trials.empty() && trials.front().has_sd);
  for (const Trial& t : trials) writer.Write(t);
}

void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, const std::string& path) {
  util::AtomicOutputFile file(path);
  WriteTrialsCsv(model, trials, file.stream());
  file.Commit();
}

}  // namespace isowrench
