#include "laser_loop_closure/core/common/file_util.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace llc {
namespace {

std::string folderOf(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
}

/// Writes and closes `out`; false (errno set) when any byte did not reach the file.
bool writeAndClose(std::FILE* out, const std::string& bytes, bool sync) {
  bool written = std::fwrite(bytes.data(), 1, bytes.size(), out) == bytes.size() && std::fflush(out) == 0;
  if (written && sync) written = ::fsync(fileno(out)) == 0;
  const int error = errno;
  const bool closed = std::fclose(out) == 0;
  if (written && !closed) return false;  // errno from fclose
  errno = error;
  return written;
}

}  // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  struct stat existing;
  if (::stat(path.c_str(), &existing) == 0 && !S_ISREG(existing.st_mode)) {
    if (S_ISDIR(existing.st_mode)) throw std::runtime_error("cannot write " + path + ": it is a folder");
    std::FILE* out = std::fopen(path.c_str(), "wb");
    if (!out) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
    if (!writeAndClose(out, bytes, false))
      throw std::runtime_error("write to " + path + " failed: " + std::strerror(errno));
    return;
  }
  const std::string temporary = path + ".tmp";
  std::FILE* out = std::fopen(temporary.c_str(), "wb");
  if (!out) throw std::runtime_error("cannot write " + temporary + ": " + std::strerror(errno));
  // Flushed to the disk before the rename, so that after a crash (even of the machine) the
  // name points at either the old bytes or all of the new ones.
  if (!writeAndClose(out, bytes, true)) {
    const int error = errno;
    std::remove(temporary.c_str());
    throw std::runtime_error("write to " + temporary + " failed: " + std::strerror(error) + " (" + path +
                             " left as it was)");
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(temporary.c_str());
    throw std::runtime_error("cannot rename " + temporary + " to " + path + ": " + std::strerror(error));
  }
  const int dir = ::open(folderOf(path).c_str(), O_RDONLY);
  if (dir >= 0) {
    ::fsync(dir);  // the rename itself; best effort
    ::close(dir);
  }
}

std::string whyNotWritable(const std::string& path) {
  if (path.empty()) return "an empty path";
  struct stat info;
  if (::stat(path.c_str(), &info) == 0) {
    if (S_ISDIR(info.st_mode)) return path + " is a folder";
    if (::access(path.c_str(), W_OK) != 0) return path + ": " + std::strerror(errno);
    if (!S_ISREG(info.st_mode)) return "";  // a device or a pipe: written in place
  }
  const std::string folder = folderOf(path);
  if (::stat(folder.c_str(), &info) != 0) return folder + ": " + std::strerror(errno);
  if (!S_ISDIR(info.st_mode)) return folder + " is not a folder";
  if (::access(folder.c_str(), W_OK | X_OK) != 0) return folder + ": " + std::strerror(errno);
  return "";
}

}  // namespace llc
