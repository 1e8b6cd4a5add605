// A CSV of postures: header of joint names (optional "label" column), one posture per row in
// degrees (mm for prismatic joints).

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "isowrench/diagnostics.hpp"
#include "isowrench/error.hpp"
#include "isowrench/posture.hpp"
#include "util/text.hpp"

namespace isowrench {
namespace {

std::vector<std::string> SplitKeepEmpty(const std::string& line) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(line);
  while (std::getline(in, item, ',')) out.push_back(util::Trim(item));
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

std::vector<NamedPosture> ParsePostureTable(const Model& model, const std::string& text,
                                            const std::string& source,
                                            const Eigen::VectorXd& base) {
  ValidatePosture(model, base);
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  std::vector<int> columns;  // joint index per column, -1 = label
  bool have_header = false;
  std::vector<NamedPosture> out;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::string trimmed = util::Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const std::string where = source + ":" + std::to_string(line_number);
    std::vector<std::string> cells = SplitKeepEmpty(trimmed);
    if (!have_header) {
      for (size_t c = 0; c < cells.size(); ++c) {
        const std::string& name = cells[c];
        if (Lower(name) == "label") {
          columns.push_back(-1);
          continue;
        }
        int index;
        try {
          index = model.JointIndex(name);
        } catch (const Error& e) {
          throw Error(where + ": column " + std::to_string(c + 1) + " header '" + name +
                      "': " + e.what());
        }
        if (std::find(columns.begin(), columns.end(), index) != columns.end()) {
          throw Error(where + ": column " + std::to_string(c + 1) + " repeats joint '" + name +
                      "'");
        }
        columns.push_back(index);
      }
      have_header = true;
      continue;
    }
    if (cells.size() != columns.size()) {
      throw Error(where + ": " + std::to_string(cells.size()) + " values for " +
                  std::to_string(columns.size()) + " header columns");
    }
    NamedPosture p;
    p.q = base;
    p.label = "row " + std::to_string(out.size() + 1);
    for (size_t c = 0; c < cells.size(); ++c) {
      if (columns[c] < 0) {
        if (!cells[c].empty()) p.label = cells[c];
        continue;
      }
      const std::string& joint = model.joint_names()[static_cast<size_t>(columns[c])];
      double value = 0.0;
      if (!util::ParseDouble(cells[c], &value) || !std::isfinite(value)) {
        throw Error(where + ": column " + std::to_string(c + 1) + " (" + joint + "): '" + cells[c] +
                    "' is not a finite number (degrees, or mm for prismatic joints)");
      }
      SetJointFromUserUnits(model, p.q, joint, value);
    }
    out.push_back(std::move(p));
  }
  if (!have_header) throw Error(source + ": no header row (joint names) found");
  if (out.empty()) throw Error(source + ": the header has no posture rows after it");
  return out;
}

std::vector<NamedPosture> ReadPostureTable(const Model& model, const std::string& path,
                                           const Eigen::VectorXd& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open posture table '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return ParsePostureTable(model, text.str(), path, base);
}

}  // namespace isowrench
