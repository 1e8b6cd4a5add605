// Measured-wrench CSV: a streaming RFC 4180 reader (one record in memory at a time) and writers.
// Format: docs/identification.md. No CSV library is used: Debian's libcsv (C, last release
// 2013) and fast-cpp-csv-parser (no quoted line breaks, fixed column count at compile time) do
// not fit; the record reader below is ~100 lines and fuzzed (fuzz/trial_csv_fuzzer.cpp).

#include "isowrench/trial_csv.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
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
  CsvRecords(std::istream& in, const std::string& source, char delimiter = ',')
      : buf_(in.rdbuf()), source_(source), delimiter_(delimiter) {
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

  /// Skip `count` physical lines (a preamble before the header), whatever they hold.
  void SkipPhysicalLines(int count) {
    for (int i = 0; i < count && buf_ && buf_->sgetc() != EOF; ++i) SkipLine();
  }

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
      while (((c = buf_->sgetc()) == ' ' || c == '\t') && c != delimiter_)
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
        while (((c = buf_->sgetc()) == ' ' || c == '\t') && c != delimiter_) buf_->sbumpc();
        if (c != delimiter_ && c != '\n' && c != '\r' && c != EOF) {
          Fail("unexpected '" + std::string(1, static_cast<char>(c)) +
               "' after a closing quote (RFC 4180: a quote inside a quoted field is written \"\")");
        }
      } else {
        while ((c = buf_->sgetc()) != EOF && c != delimiter_ && c != '\n' && c != '\r') {
          Add(&field, static_cast<char>(buf_->sbumpc()));
        }
      }
      fields->push_back(quoted ? field : util::Trim(field));
      c = buf_->sgetc();
      if (c == delimiter_) {
        buf_->sbumpc();
        continue;
      }
      if (c != EOF) EndOfLine();
      return;
    }
  }

  std::streambuf* buf_;
  const std::string& source_;
  int delimiter_ = ',';
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
    "isowrench reads it with the sheet's separator and decimal mark declared (isowrench fit "
    "--delimiter ';' --decimal-comma; Python delimiter=';', decimal_comma=True), or export it "
    "as 'CSV (comma delimited)'";

// ---- Units in headers ("fx (N)", "hip_rz [rad]") and units rows -------------------------------

/// What a column holds, for its unit.
enum class Quantity { kAngle, kLength, kForce, kMoment, kFraction, kText };

const char* QuantityUnits(Quantity q) {
  switch (q) {
    case Quantity::kAngle: return "deg or rad";
    case Quantity::kLength: return "mm, cm or m";
    case Quantity::kForce: return "N, mN or kN";
    case Quantity::kMoment: return "N·m, N·mm, N·cm, mN·m or kN·m";
    case Quantity::kFraction: return "1 or %";
    case Quantity::kText: return "none";
  }
  return "";
}

/// The unit without the separators people write between N and m ("N·m", "N.m", "N m", "N*m",
/// "N⋅m", "Nm" are one unit).
std::string CompactUnit(std::string unit) {
  for (const char* sep : {"\xC2\xB7", "\xE2\x8B\x85", "*", ".", " ", "-"}) {
    for (size_t at; (at = unit.find(sep)) != std::string::npos;) unit.erase(at, std::strlen(sep));
  }
  return unit;
}

/// Factor from `unit` to the model's units (rad, m, N, N·m, fraction) for quantity q; false
/// when the unit is not one of q's. An empty unit is the default: degrees, millimetres, N, N·m.
bool UnitFactor(const std::string& unit_text, Quantity q, double* factor) {
  const std::string unit = util::Trim(unit_text);
  std::string lower = unit;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const std::string compact = CompactUnit(unit);
  switch (q) {
    case Quantity::kAngle:
      if (unit.empty() || lower == "deg" || lower == "degree" || lower == "degrees" ||
          unit == "\xC2\xB0") {
        *factor = M_PI / 180.0;
        return true;
      }
      if (lower == "rad" || lower == "radian" || lower == "radians") {
        *factor = 1.0;
        return true;
      }
      return false;
    case Quantity::kLength: {
      static const std::map<std::string, double> kLengths = {
          {"", 1e-3}, {"mm", 1e-3}, {"cm", 1e-2}, {"m", 1.0}, {"um", 1e-6}, {"\xC2\xB5m", 1e-6}};
      auto it = kLengths.find(unit);
      if (it == kLengths.end()) return false;
      *factor = it->second;
      return true;
    }
    case Quantity::kForce: {
      static const std::map<std::string, double> kForces = {
          {"", 1.0}, {"N", 1.0}, {"mN", 1e-3}, {"kN", 1e3}};
      auto it = kForces.find(unit);
      if (it == kForces.end()) return false;
      *factor = it->second;
      return true;
    }
    case Quantity::kMoment: {
      static const std::map<std::string, double> kMoments = {
          {"", 1.0},     {"Nm", 1.0},  {"Nmm", 1e-3}, {"Ncm", 1e-2},
          {"mNm", 1e-3}, {"kNm", 1e3}, {"mNmm", 1e-6}};
      auto it = kMoments.find(compact);
      if (it == kMoments.end()) return false;
      *factor = it->second;
      return true;
    }
    case Quantity::kFraction:
      if (unit.empty() || unit == "1" || unit == "-" || lower == "fraction") {
        *factor = 1.0;
        return true;
      }
      if (unit == "%") {
        *factor = 0.01;
        return true;
      }
      return false;
    case Quantity::kText: return unit.empty() || unit == "-";
  }
  return false;
}

/// True when `cell` is a unit of some quantity (a cell of a units row).
bool IsUnitCell(const std::string& cell) {
  double factor;
  if (util::Trim(cell).empty()) return true;
  for (Quantity q : {Quantity::kAngle, Quantity::kLength, Quantity::kForce, Quantity::kMoment,
                     Quantity::kFraction}) {
    if (UnitFactor(cell, q, &factor)) return true;  // "1" too: the unit of a fraction
  }
  return false;
}

/// "fx (N)" -> {"fx", "N"}, "hip_rz [rad]" -> {"hip_rz", "rad"}, "fx" -> {"fx", ""}; `has_unit`
/// says whether brackets were there.
std::pair<std::string, std::string> SplitUnit(const std::string& header, bool* has_unit) {
  const std::string h = util::Trim(header);
  *has_unit = false;
  if (h.size() >= 3 && (h.back() == ')' || h.back() == ']')) {
    const char open = h.back() == ')' ? '(' : '[';
    const size_t at = h.rfind(open);
    if (at != std::string::npos && at > 0) {
      *has_unit = true;
      return {util::Trim(h.substr(0, at)), util::Trim(h.substr(at + 1, h.size() - at - 2))};
    }
  }
  return {h, ""};
}

}  // namespace

struct TrialReader::Impl {
  const Model* model = nullptr;
  TrialSheetOptions sheet;
  std::istream* input = nullptr;
  std::string source;
  std::unique_ptr<CsvRecords> records;
  long line_number = 0;
  std::vector<std::string> columns;  ///< the header's cells, as written
  std::vector<std::string> fields;   ///< the current record (reused: no allocation per row)
  std::vector<std::string> pending;  ///< a record read ahead (the row after the header)
  long pending_line = 0;
  bool has_pending = false;
  std::vector<int> joint_column;  ///< per file column: model joint index or -1
  std::vector<double> factor;     ///< per file column: file unit -> model unit (rad, m, N, N·m)
  std::vector<std::string> unit;  ///< per file column: the unit as written ("" = default)
  std::vector<bool> warned;       ///< per file column: a range warning was issued
  std::vector<double> largest;    ///< per joint column: largest |value| read (model units)
  int muscle_column = -1;
  int activation_column = -1;
  int wrench_column[6] = {-1, -1, -1, -1, -1, -1};
  int sd_column[6] = {-1, -1, -1, -1, -1, -1};
  bool has_sd = false;
  long rows = 0;
  bool unit_checked = false;  ///< the end-of-file unit slip check ran
  Eigen::VectorXd nominal;
  double limb_length = 0;  ///< LimbLength of the model (plausibility of prismatic columns)
  std::shared_ptr<const std::vector<std::string>> joint_names;

  std::string Where(int column) const {
    std::string s = source + ":" + std::to_string(line_number);
    if (column >= 0) s += ", column " + std::to_string(column + 1) + " '" + columns[column] + "'";
    return s;
  }

  bool NextRecord(std::vector<std::string>* out, long* line) {
    if (has_pending) {
      has_pending = false;
      *out = std::move(pending);
      *line = pending_line;
      return true;
    }
    return records->Next(out, line);
  }

  /// A number of column c of the current record, in the file's unit.
  double Number(int c) const {
    std::string text = fields[c];
    if (sheet.decimal_comma) std::replace(text.begin(), text.end(), ',', '.');
    double v = 0.0;
    if (!util::ParseDouble(text, &v)) {
      if (!sheet.decimal_comma && LooksLikeDecimalComma(fields[c])) {
        throw Error(Where(c) + ": '" + fields[c] + "' uses a decimal comma; " + kSeparatorAdvice);
      }
      throw Error(Where(c) + ": '" + fields[c] + "' is not a number");
    }
    if (!std::isfinite(v)) throw Error(Where(c) + ": value '" + fields[c] + "' is not finite");
    return v;
  }

  /// Set column c's unit (header or units row); false when it is not a unit of q.
  bool SetUnit(int c, const std::string& text, Quantity q) {
    double f = 1.0;
    if (!UnitFactor(text, q, &f)) return false;
    factor[c] = f;
    unit[c] = util::Trim(text);
    return true;
  }

  Quantity ColumnQuantity(int c) const {
    if (c == muscle_column) return Quantity::kText;
    if (c == activation_column) return Quantity::kFraction;
    if (joint_column[c] >= 0) {
      return model->joint(joint_column[c]).type == JointType::kPrismatic ? Quantity::kLength
                                                                         : Quantity::kAngle;
    }
    for (int i = 0; i < 6; ++i) {
      if (c == wrench_column[i] || c == sd_column[i])
        return i < 3 ? Quantity::kForce : Quantity::kMoment;
    }
    return Quantity::kText;  // ignored columns
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
  if (sheet.delimiter != ',' && sheet.delimiter != ';' && sheet.delimiter != '\t' &&
      sheet.delimiter != '|') {
    throw Error(m.source + ": the delimiter must be ',', ';', a tab or '|', not '" +
                std::string(1, sheet.delimiter) + "'");
  }
  if (sheet.decimal_comma && sheet.delimiter == ',') {
    throw Error(m.source +
                ": decimal commas need another delimiter (';' or a tab): with ',' between the "
                "fields '1,5' would be two fields");
  }
  if (sheet.skip_rows < 0) {
    throw Error(m.source + ": skip_rows must be >= 0, got " + std::to_string(sheet.skip_rows));
  }
  m.records = std::make_unique<CsvRecords>(input, m.source, sheet.delimiter);
  m.records->SkipPhysicalLines(sheet.skip_rows);
  if (!m.records->Next(&m.columns, &m.line_number)) {
    throw Error(m.source +
                ": no header line (expected column names such as muscle,fx,fy,fz,mx,my,mz)");
  }
  for (std::string& name : m.columns) name = util::Trim(name);
  if (m.columns.size() == 1) {
    for (char separator : {';', '\t', '|', ','}) {
      if (separator == sheet.delimiter) continue;
      if (m.columns[0].find(separator) != std::string::npos) {
        std::string shown =
            separator == '\t' ? std::string("a tab") : "'" + std::string(1, separator) + "'";
        throw Error(m.Where(-1) + ": the header '" + m.columns[0] + "' uses " + shown +
                    " as the separator (a spreadsheet export in a locale with decimal commas?); " +
                    kSeparatorAdvice);
      }
    }
  }
  const size_t n = m.columns.size();
  m.joint_column.assign(n, -1);
  m.factor.assign(n, 1.0);
  m.unit.assign(n, "");
  m.warned.assign(n, false);
  m.largest.assign(n, 0.0);
  std::map<std::string, int> seen;
  const std::vector<std::string>& joints = model.joint_names();
  std::vector<bool> joint_present(joints.size(), false);
  std::vector<std::string> header_unit(n);
  std::vector<bool> has_header_unit(n, false);
  std::vector<bool> active(n, false);  // a column isowrench reads (known, not ignored)
  std::vector<std::string> unknown;
  std::vector<std::string> known = joints;
  for (const char* k : {"muscle", "activation"}) known.push_back(k);
  for (int i = 0; i < 6; ++i) {
    known.push_back(kWrenchColumns[i]);
    known.push_back(kSdColumns[i]);
  }
  auto ignored = [&](const std::string& written, const std::string& name) {
    for (const std::string& i : sheet.ignore_columns) {
      if (util::Trim(i) == written || util::Trim(i) == name) return true;
    }
    return false;
  };
  for (size_t c = 0; c < n; ++c) {
    bool with_unit = false;
    const auto [name, unit] = SplitUnit(m.columns[c], &with_unit);
    const int col = static_cast<int>(c);
    if (name.empty())
      throw Error(m.Where(-1) + ", column " + std::to_string(c + 1) + ": empty column name");
    if (ignored(m.columns[c], name)) continue;
    if (seen.count(name)) {
      throw Error(m.Where(col) + ": duplicate column (also column " +
                  std::to_string(seen[name] + 1) + ")");
    }
    seen[name] = col;
    header_unit[c] = unit;
    has_header_unit[c] = with_unit;
    bool matched = true;
    if (name == "muscle") {
      m.muscle_column = col;
    } else if (name == "activation") {
      m.activation_column = col;
    } else {
      matched = false;
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
      for (size_t j = 0; j < joints.size() && !matched; ++j) {
        if (joints[j] == name) {
          m.joint_column[c] = static_cast<int>(j);
          joint_present[j] = true;
          matched = true;
        }
      }
    }
    if (!matched) {
      unknown.push_back("'" + m.columns[c] + "'" + DidYouMean(name, known));
    } else {
      active[c] = true;
    }
  }
  // Units: the defaults (deg, mm, N, N·m), then the header's, checked against the column's
  // quantity.
  for (size_t c = 0; c < n; ++c) {
    if (active[c]) m.SetUnit(static_cast<int>(c), "", m.ColumnQuantity(static_cast<int>(c)));
  }
  for (size_t c = 0; c < n; ++c) {
    const int col = static_cast<int>(c);
    const Quantity q = m.ColumnQuantity(col);
    if (!has_header_unit[c] || !active[c]) continue;
    if (!m.SetUnit(col, header_unit[c], q)) {
      throw Error(m.Where(col) + ": unit '" + header_unit[c] + "' is not a unit of this column (" +
                  QuantityUnits(q) + ")");
    }
  }
  // A units row right under the header ("deg,deg,,N,N,N,N·m,..."): read it as the units.
  if (m.records->Next(&m.pending, &m.pending_line)) {
    m.has_pending = true;
    bool units_row = m.pending.size() == n;
    bool any = false;
    for (size_t c = 0; units_row && c < n; ++c) {
      double number = 0;
      if (active[c] ? !IsUnitCell(m.pending[c]) : util::ParseDouble(m.pending[c], &number)) {
        units_row = false;
      }
      any = any || (active[c] && !util::Trim(m.pending[c]).empty());
    }
    if (units_row && any) {
      m.has_pending = false;
      for (size_t c = 0; c < n; ++c) {
        const int col = static_cast<int>(c);
        const std::string cell = util::Trim(m.pending[c]);
        if (cell.empty() || !active[c]) continue;
        const Quantity q = m.ColumnQuantity(col);
        if (!header_unit[c].empty() && header_unit[c] != cell) {
          throw Error(m.source + ":" + std::to_string(m.pending_line) + ", column " +
                      std::to_string(c + 1) + " '" + m.columns[c] + "': the units row says '" +
                      cell + "' but the header says '" + header_unit[c] + "'");
        }
        if (!m.SetUnit(col, cell, q)) {
          throw Error(m.source + ":" + std::to_string(m.pending_line) + ", column " +
                      std::to_string(c + 1) + " '" + m.columns[c] + "': unit '" + cell +
                      "' in the units row is not a unit of this column (" + QuantityUnits(q) + ")");
        }
      }
    }
  }
  if (!unknown.empty()) {
    Warn(m.Where(-1) + ": ignoring column" + (unknown.size() > 1 ? "s " : " ") +
         util::Join(unknown, ", ") + ": not a joint of model '" + model.name() + "' (" +
         util::Join(joints, ", ") +
         ") nor one of muscle, activation, fx fy fz mx my mz, sd_fx ... sd_mz (list the columns "
         "to ignore to silence this: --ignore-columns; Python ignore_columns=)");
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
  if (!m.NextRecord(&fields, &m.line_number)) {
    if (m.input->bad())
      throw Error(m.source + ": read error after line " + std::to_string(m.records->line()));
    // At the end: the unit slip a whole file shows (angles in radians read as degrees).
    std::vector<std::pair<int, double>> angles;
    for (size_t c = 0; c < m.columns.size(); ++c) {
      if (m.joint_column[c] >= 0) angles.emplace_back(m.joint_column[c], m.largest[c]);
    }
    if (m.rows > 0 && m.unit_checked == false) {
      m.unit_checked = true;
      const std::string w = RadianSlipWarning(*m.model, angles);
      if (!w.empty()) Warn(m.source + ": " + w);
    }
    return false;
  }
  if (fields.size() != m.columns.size()) {
    std::string hint;
    if (fields.size() > m.columns.size() && m.sheet.delimiter == ',') {
      hint = " (decimal commas? '1,5' must be written 1.5, or ";
      hint += kSeparatorAdvice;
      hint += ")";
    } else if (fields.size() == 1 && fields[0].find(';') != std::string::npos) {
      hint = std::string(" (';' separators? ") + kSeparatorAdvice + ")";
    }
    throw Error(m.Where(-1) + ": expected " + std::to_string(m.columns.size()) +
                " fields (as the header), found " + std::to_string(fields.size()) + hint);
  }
  Trial t;
  t.line = m.line_number;
  t.joint_names = m.joint_names;
  t.q = m.nominal;
  for (size_t c = 0; c < fields.size(); ++c) {
    int j = m.joint_column[c];
    if (j < 0) continue;
    if (m.sheet.postures_only && fields[c].empty()) continue;  // the nominal value
    int col = static_cast<int>(c);
    const double written = m.Number(col);
    const double v = written * m.factor[c];  // rad or m
    JointType type = m.model->joint(j).type;
    bool revolute = type == JointType::kRevolute;
    // Values that cannot be a joint position at all are errors; implausible ones (outside the
    // joint's limits, beyond a full turn, a translation longer than the limb) warn, once per
    // column, from the one place every reader asks (CoordinateValueWarning).
    const double impossible = revolute ? kImpossibleRevolute : kImpossiblePrismatic;
    if (!(std::abs(v) <= impossible)) {
      throw Error(m.Where(col) + ": " + fields[c] + " " +
                  (m.unit[c].empty() ? (revolute ? "deg" : "mm") : m.unit[c]) +
                  " cannot be a joint position (|value| > " +
                  util::FormatNumber(revolute ? 360e3 : 2e6) + (revolute ? " deg)" : " mm)"));
    }
    t.q[j] = v;
    m.largest[c] = std::max(m.largest[c], std::abs(v));
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
    t.activation = m.Number(m.activation_column) * m.factor[m.activation_column];
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
    t.wrench[i] = m.Number(c) * m.factor[c];
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
      t.sd[i] = m.Number(c) * m.factor[c];
      if (!(t.sd[i] > 0))
        throw Error(m.Where(c) + ": standard deviation " + fields[c] + " must be > 0");
      if (t.sd[i] > kMaxMeasuredWrench) {
        throw Error(m.Where(c) + ": standard deviation " + fields[c] + " is not plausible (> " +
                    util::FormatNumber(kMaxMeasuredWrench) + ")");
      }
    }
  }
  ++m.rows;
  *trial = std::move(t);
  return true;
}

std::string RadianSlipWarning(const Model& model,
                              const std::vector<std::pair<int, double>>& largest) {
  const Eigen::VectorXd nominal = model.nominal_posture();
  std::vector<std::string> columns, posture;
  double widest = 0.0;
  bool far = false;
  for (const auto& [j, value] : largest) {
    if (j < 0 || j >= model.dof_count() || model.coordinate(j).type != JointType::kRevolute ||
        model.coordinate(j).role != JointRole::kLimb) {
      continue;
    }
    if (value * 180.0 / M_PI > kRadianSlipDegrees) return "";  // a real angle somewhere
    widest = std::max(widest, value);
    columns.push_back(model.joint_names()[static_cast<size_t>(j)]);
    if (std::abs(nominal[j]) * 180.0 / M_PI > kRadianSlipNominalDegrees) {
      far = true;
      posture.push_back(columns.back() + " = " + util::FormatNumber(nominal[j] * 180.0 / M_PI, 4) +
                        "°");
    }
  }
  if (columns.empty() || !far) return "";
  return "the angles of " + util::Join(columns, ", ") + " all stay within ±" +
         util::FormatNumber(widest * 180.0 / M_PI, 3) + "° of 0 while the model's posture is " +
         util::Join(posture, ", ") +
         ": recorded in radians? (the angle columns are read as degrees unless the header says "
         "otherwise: write 'hip_rz (rad)', or a units row with rad)";
}

std::vector<std::string> UnitSlips(const Model& nominal, const std::vector<Trial>& trials,
                                   const std::vector<Vector6d>& predicted) {
  std::vector<std::string> out;
  if (trials.empty() || trials.size() != predicted.size()) return out;
  // Angles: the coordinates the trials set (a coordinate without a column is at its nominal
  // value in every trial, and says nothing about the file's unit).
  const Eigen::VectorXd q0 = nominal.nominal_posture();
  std::vector<std::pair<int, double>> largest;
  for (int j = 0; j < nominal.dof_count(); ++j) {
    bool set = false;
    double widest = 0.0;
    for (const Trial& t : trials) {
      if (t.q.size() != q0.size()) return out;
      set = set || t.q[j] != q0[j];
      widest = std::max(widest, std::abs(t.q[j]));
    }
    if (set) largest.emplace_back(j, widest);
  }
  const std::string radians = RadianSlipWarning(nominal, largest);
  if (!radians.empty()) out.push_back(radians);
  // Axes: the least-squares factor of measured on predicted.
  struct Slip {
    double factor;
    const char* force_hint;
    const char* moment_hint;
  };
  const Slip slips[] = {
      {-1.0,
       "sign convention? isowrench's measured wrench is the one the limb applies to the "
       "transducer (docs/model.md): if the transducer reports the reaction, negate these columns",
       "sign convention? isowrench's measured wrench is the one the limb applies to the "
       "transducer (docs/model.md): if the transducer reports the reaction, negate these "
       "columns"},
      {1000.0, "forces in mN? declare the unit in the header ('fx (mN)') and isowrench converts it",
       "moments in N·mm? declare the unit in the header ('mx (N·mm)') and isowrench converts it"},
      {-1000.0, "forces in mN and the reaction's sign? ('fx (mN)', and negate the columns)",
       "moments in N·mm and the reaction's sign? ('mx (N·mm)', and negate the columns)"},
      {0.001, "forces in kN? ('fx (kN)')", "moments in kN·m? ('mx (kN·m)')"},
  };
  const char* names[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (const Slip& slip : slips) {
    for (int half = 0; half < 2; ++half) {
      // A unit or sign slip is the file's, so it shows on all three forces (or moments) at
      // once: one axis alone near -1 is an effect the model lacks, not a convention.
      std::vector<std::string> axes, factors;
      for (int c = 3 * half; c < 3 * half + 3; ++c) {
        double mp = 0, pp = 0, mm = 0;
        for (size_t k = 0; k < trials.size(); ++k) {
          mp += trials[k].wrench[c] * predicted[k][c];
          pp += predicted[k][c] * predicted[k][c];
          mm += trials[k].wrench[c] * trials[k].wrench[c];
        }
        if (!(pp > 0) || !(mm > 0)) continue;
        const double factor = mp / pp;
        const double unexplained = (mm - 2 * factor * mp + factor * factor * pp) / mm;
        if (std::abs(factor / slip.factor - 1.0) < kSlipFactorTolerance &&
            unexplained < kSlipUnexplainedFraction) {
          axes.push_back(names[c]);
          factors.push_back(util::FormatNumber(factor, 4));
        }
      }
      if (axes.size() != 3) continue;
      out.push_back("measured = " + util::FormatNumber(slip.factor) + " x predicted on " +
                    util::Join(axes, ", ") + " (least-squares factors " +
                    util::Join(factors, ", ") +
                    "): " + (half == 0 ? slip.force_hint : slip.moment_hint));
    }
  }
  return out;
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
