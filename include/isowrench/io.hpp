#pragma once
/// @file
/// Small text and file helpers shared by the library and the command-line tool: locale-independent
/// number parsing and formatting, string splitting, and output files that appear only complete
/// (written under a temporary name, renamed on success), so an error never leaves a partial file.

#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace isowrench::util {

/// Parse a whole string as a double, independent of the C/C++ locale (std::from_chars).
/// Leading/trailing blanks and a leading '+' are accepted. Returns false if the text is not
/// entirely a number. "nan"/"inf" parse (callers check std::isfinite).
bool ParseDouble(std::string_view text, double* value);

/// ParseDouble that throws.
/// @throws isowrench::Error "<context>: '<text>' is not a number".
double ParseDoubleOrThrow(std::string_view text, const std::string& context);

/// Split on any of `separators`, dropping empty pieces and trimming blanks from each piece.
std::vector<std::string> Split(std::string_view text, std::string_view separators);

/// `text` without leading and trailing blanks (space, tab, CR, LF).
std::string Trim(std::string_view text);

/// Format with %g-like precision (`significant` digits), locale independent (std::to_chars).
std::string FormatNumber(double value, int significant = 6);

/// Join strings with a separator.
std::string Join(const std::vector<std::string>& items, const std::string& separator);

/// Write `content` to `path` atomically (temporary file in the same directory, then rename).
/// @throws isowrench::Error naming the path when it cannot be written.
void WriteFileAtomically(const std::string& path, const std::string& content);

/// Streaming variant: write to stream(), then Commit(). Destruction without Commit() removes
/// the temporary file, so the destination is never left half-written.
class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(std::string path);  ///< @throws isowrench::Error naming the path
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  std::ofstream& stream() { return stream_; }
  void Commit();  ///< flush, close and rename. @throws isowrench::Error naming the path

 private:
  std::string path_;
  std::string temp_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace isowrench::util
