// Measured-wrench CSV: a streaming reader (one line in memory at a time) and a writer.
// Format: docs/identification.md.

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "identification/identification_impl.hpp"
#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "util/atomic_file.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

const char* kWrenchColumns[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
const char* kSdColumns[6] = {"sd_fx", "sd_fy", "sd_fz", "sd_mx", "sd_my", "sd_mz"};

/// Split one CSV line on commas, keeping empty fields (quotes are not supported).
std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  while (true) {
    size_t comma = line.find(',', start);
    fields.push_back(util::Trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

bool SkipLine(const std::string& line) {
  std::string t = util::Trim(line);
  return t.empty() || t[0] == '#';
}

}  // namespace

struct TrialReader::Impl {
  const Model* model = nullptr;
  std::istream* input = nullptr;
  std::string source;
  long line_number = 0;
  std::vector<std::string> columns;
  std::vector<int> joint_column;  ///< per file column: model joint index or -1
  int muscle_column = -1;
  int activation_column = -1;
  int wrench_column[6] = {-1, -1, -1, -1, -1, -1};
  int sd_column[6] = {-1, -1, -1, -1, -1, -1};
  bool has_sd = false;
  Eigen::VectorXd nominal;
  std::shared_ptr<const std::vector<std::string>> joint_names;

  std::string Where(int column) const {
    std::string s = source + ":" + std::to_string(line_number);
    if (column >= 0) s += ", column " + std::to_string(column + 1) + " '" + columns[column] + "'";
    return s;
  }
};

TrialReader::TrialReader(const Model& model, std::istream& input, std::string source_name)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.model = &model;
  m.input = &input;
  m.source = std::move(source_name);
  m.nominal = model.nominal_posture();
  m.joint_names = std::make_shared<const std::vector<std::string>>(model.joint_names());
  std::string line;
  bool found = false;
  while (std::getline(input, line)) {
    ++m.line_number;
    if (SkipLine(line)) continue;
    found = true;
    break;
  }
  if (!found) throw Error(m.source + ": no header line (expected column names such as muscle,fx,fy,fz,mx,my,mz)");
  m.columns = SplitFields(line);
  m.joint_column.assign(m.columns.size(), -1);
  std::map<std::string, int> seen;
  for (size_t c = 0; c < m.columns.size(); ++c) {
    const std::string& name = m.columns[c];
    int col = static_cast<int>(c);
    if (name.empty()) throw Error(m.Where(-1) + ", column " + std::to_string(c + 1) + ": empty column name");
    if (seen.count(name)) {
      throw Error(m.Where(col) + ": duplicate column (also column " + std::to_string(seen[name] + 1) + ")");
    }
    seen[name] = col;
    if (name == "muscle") { m.muscle_column = col; continue; }
    if (name == "activation") { m.activation_column = col; continue; }
    bool matched = false;
    for (int i = 0; i < 6; ++i) {
      if (name == kWrenchColumns[i]) { m.wrench_column[i] = col; matched = true; }
      if (name == kSdColumns[i]) { m.sd_column[i] = col; matched = true; }
    }
    if (matched) continue;
    const std::vector<std::string>& joints = model.joint_names();
    for (size_t j = 0; j < joints.size(); ++j) {
      if (joints[j] == name) { m.joint_column[c] = static_cast<int>(j); matched = true; }
    }
    if (!matched) {
      throw Error(m.Where(col) + ": unknown column: not a joint of model '" + model.name() + "' (" +
                  util::Join(joints, ", ") + ") nor one of muscle, activation, fx fy fz mx my mz, sd_fx ... sd_mz");
    }
  }
  std::vector<std::string> missing;
  if (m.muscle_column < 0) missing.push_back("muscle");
  for (int i = 0; i < 6; ++i) {
    if (m.wrench_column[i] < 0) missing.push_back(kWrenchColumns[i]);
  }
  int sd_count = 0;
  for (int i = 0; i < 6; ++i) sd_count += m.sd_column[i] >= 0;
  if (sd_count != 0 && sd_count != 6) {
    for (int i = 0; i < 6; ++i) {
      if (m.sd_column[i] < 0) missing.push_back(kSdColumns[i]);
    }
  }
  if (!missing.empty()) {
    throw Error(m.Where(-1) + ": header lacks required column(s) " + util::Join(missing, ", ") +
                " (sd columns: all six or none)");
  }
  m.has_sd = sd_count == 6;
}

TrialReader::~TrialReader() = default;

const std::vector<std::string>& TrialReader::columns() const { return impl_->columns; }

bool TrialReader::Next(Trial* trial) {
  Impl& m = *impl_;
  std::string line;
  while (std::getline(*m.input, line)) {
    ++m.line_number;
    if (SkipLine(line)) continue;
    std::vector<std::string> fields = SplitFields(line);
    if (fields.size() != m.columns.size()) {
      throw Error(m.Where(-1) + ": expected " + std::to_string(m.columns.size()) + " fields (as the header), found " +
                  std::to_string(fields.size()));
    }
    auto number = [&](int c) {
      double v = 0.0;
      if (!util::ParseDouble(fields[c], &v)) {
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
      double v = number(static_cast<int>(c));
      t.q[j] = JointValueFromUserUnits(m.model->joint(j).type, v);
    }
    t.muscle = fields[m.muscle_column];
    try {
      m.model->MuscleIndex(t.muscle);
    } catch (const Error& e) {
      throw Error(m.Where(m.muscle_column) + ": " + e.what());
    }
    if (m.activation_column >= 0) {
      t.activation = number(m.activation_column);
      if (t.activation < 0) throw Error(m.Where(m.activation_column) + ": activation " + fields[m.activation_column] + " must be >= 0");
    }
    for (int i = 0; i < 6; ++i) t.wrench[i] = number(m.wrench_column[i]);
    t.has_sd = m.has_sd;
    if (m.has_sd) {
      for (int i = 0; i < 6; ++i) {
        t.sd[i] = number(m.sd_column[i]);
        if (!(t.sd[i] > 0)) throw Error(m.Where(m.sd_column[i]) + ": standard deviation " + fields[m.sd_column[i]] + " must be > 0");
      }
    }
    *trial = std::move(t);
    return true;
  }
  if (m.input->bad()) throw Error(m.source + ": read error after line " + std::to_string(m.line_number));
  return false;
}

std::vector<Trial> ReadTrialsCsv(const Model& model, const std::string& path) {
  std::ifstream file(path);
  if (!file) throw Error("cannot open data file '" + path + "'");
  TrialReader reader(model, file, path);
  std::vector<Trial> trials;
  Trial t;
  while (reader.Next(&t)) trials.push_back(std::move(t));
  if (trials.empty()) throw Error(path + ": no trials (only a header)");
  return trials;
}

void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, std::ostream& out) {
  bool sd = !trials.empty() && trials.front().has_sd;
  const std::vector<std::string>& joints = model.joint_names();
  out << "# isowrench measured wrenches; joints in degrees (mm for prismatic), forces N, moments N·m, "
         "transducer axes\n";
  for (size_t j = 0; j < joints.size(); ++j) out << joints[j] << ",";
  out << "muscle,activation,fx,fy,fz,mx,my,mz";
  if (sd) out << ",sd_fx,sd_fy,sd_fz,sd_mx,sd_my,sd_mz";
  out << "\n";
  for (const Trial& t : trials) {
    std::vector<int> map = t.joint_names ? ident::JointMap(model, *t.joint_names) : std::vector<int>();
    Eigen::VectorXd q = model.nominal_posture();
    if (t.joint_names) {
      for (size_t i = 0; i < map.size(); ++i) {
        if (map[i] >= 0) q[map[i]] = t.q[i];
      }
    } else if (t.q.size() == q.size()) {
      q = t.q;
    }
    for (int j = 0; j < q.size(); ++j) {
      double v = JointValueToUserUnits(model.joint(j).type, q[j]);
      out << util::FormatNumber(v, 10) << ",";
    }
    out << t.muscle << "," << util::FormatNumber(t.activation, 10);
    for (int i = 0; i < 6; ++i) out << "," << util::FormatNumber(t.wrench[i], 10);
    if (sd) {
      for (int i = 0; i < 6; ++i) out << "," << util::FormatNumber(t.sd[i], 10);
    }
    out << "\n";
  }
}

void WriteTrialsCsv(const Model& model, const std::vector<Trial>& trials, const std::string& path) {
  util::AtomicOutputFile file(path);
  WriteTrialsCsv(model, trials, file.stream());
  file.Commit();
}

}  // namespace isowrench
