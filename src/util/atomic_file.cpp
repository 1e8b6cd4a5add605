#include "util/atomic_file.hpp"

#include <unistd.h>

#include <cstdio>

#include "isowrench/error.hpp"

namespace isowrench::util {

AtomicOutputFile::AtomicOutputFile(std::string path) : path_(std::move(path)) {
  temp_path_ = path_ + ".tmp." + std::to_string(::getpid());
  stream_.open(temp_path_, std::ios::binary | std::ios::trunc);
  if (!stream_) throw Error("cannot open '" + path_ + "' for writing");
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!committed_) {
    stream_.close();
    std::remove(temp_path_.c_str());
  }
}

void AtomicOutputFile::Commit() {
  stream_.flush();
  bool good = static_cast<bool>(stream_);
  stream_.close();
  if (!good || std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    std::remove(temp_path_.c_str());
    committed_ = true;
    throw Error("cannot write '" + path_ + "'");
  }
  committed_ = true;
}

void WriteFileAtomically(const std::string& path, const std::string& content) {
  AtomicOutputFile file(path);
  file.stream() << content;
  file.Commit();
}

}  // namespace isowrench::util
