// PNG output through an external SVG rasterizer found at run time (rsvg-convert or ImageMagick).
// No rasterizer is a dependency: without one, PNG output is skipped with a note.

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "isowrench/plots.hpp"
#include "util/text.hpp"

extern char** environ;

namespace isowrench {
namespace {

std::string FindOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  for (const std::string& dir : util::Split(path, ":")) {
    std::string candidate = dir + "/" + name;
    struct stat st {};
    if (::stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        ::access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
  }
  return "";
}

// Run argv with stdout/stderr sent to `output_file` (or /dev/null); returns the exit status, or
// -1 if it could not be started or was killed.
int Run(const std::vector<std::string>& args, const std::string& output_file = "/dev/null") {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, output_file.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  int status = 0;
  if (::waitpid(pid, &status, 0) < 0 || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

bool IsImageMagick(const std::string& tool) {
  char name[] = "/tmp/isowrench-im-XXXXXX";
  int fd = ::mkstemp(name);
  if (fd < 0) return false;
  ::close(fd);
  bool ok = Run({tool, "-version"}, name) == 0;
  std::ifstream in(name);
  std::string first;
  std::getline(in, first);
  std::remove(name);
  // The real tool prints "Version: ImageMagick ..."; anything else (a stand-in) is not used.
  return ok && first.rfind("Version: ImageMagick", 0) == 0;
}

bool HasPngSignature(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::string(magic, 8) == std::string("\x89PNG\r\n\x1a\n", 8);
}

}  // namespace

std::string FindSvgRasterizer() {
  if (std::string rsvg = FindOnPath("rsvg-convert"); !rsvg.empty()) return rsvg;
  for (const char* name : {"magick", "convert"}) {
    std::string tool = FindOnPath(name);
    if (!tool.empty() && IsImageMagick(tool)) return tool;
  }
  return "";
}

bool RasterizeSvgToPng(const std::string& svg_path, const std::string& png_path,
                       std::string* message) {
  std::string tool = FindSvgRasterizer();
  if (tool.empty()) {
    if (message)
      *message =
          "PNG skipped: no SVG rasterizer found (install rsvg-convert or ImageMagick); the SVG is "
          "complete";
    return false;
  }
  const std::string temp = png_path + ".tmp." + std::to_string(::getpid()) + ".png";
  const bool rsvg = tool.size() >= 12 && tool.compare(tool.size() - 12, 12, "rsvg-convert") == 0;
  const int rc = rsvg ? Run({tool, "-f", "png", "-o", temp, svg_path})
                      : Run({tool, "-density", "96", svg_path, "png:" + temp});
  if (rc != 0 || !HasPngSignature(temp) || std::rename(temp.c_str(), png_path.c_str()) != 0) {
    std::remove(temp.c_str());
    if (message)
      *message = "PNG skipped: " + tool + " failed on '" + svg_path + "' (exit " +
                 std::to_string(rc) + ")";
    return false;
  }
  if (message) message->clear();
  return true;
}

}  // namespace isowrench
