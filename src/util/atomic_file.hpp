#pragma once
// Private helper: write output files to a temporary name and rename on success, so an error
// never leaves a partial file behind.

#include <fstream>
#include <string>

namespace isowrench::util {

/// Write `content` to `path` atomically. @throws isowrench::Error naming the path.
void WriteFileAtomically(const std::string& path, const std::string& content);

/// Streaming variant: write to stream(), then Commit(). Destruction without Commit() removes
/// the temporary file.
class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(std::string path);  ///< @throws isowrench::Error
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  std::ofstream& stream() { return stream_; }
  void Commit();  ///< flush, close and rename. @throws isowrench::Error

 private:
  std::string path_;
  std::string temp_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace isowrench::util
