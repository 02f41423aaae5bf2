#include "laser_loop_closure/core/file_util.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace llc {

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp";
  std::FILE* out = std::fopen(temporary.c_str(), "wb");
  if (!out) throw std::runtime_error("cannot write " + temporary + ": " + std::strerror(errno));
  // Flushed to the disk before the rename, so that after a crash (even of the machine) the
  // name points at either the old bytes or all of the new ones.
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), out) == bytes.size() && std::fflush(out) == 0 &&
                       ::fsync(fileno(out)) == 0;
  const int error = errno;
  if (std::fclose(out) != 0 || !written) {
    std::remove(temporary.c_str());
    throw std::runtime_error("write to " + temporary + " failed: " + std::strerror(error));
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0)
    throw std::runtime_error("cannot rename " + temporary + " to " + path + ": " + std::strerror(errno));
  const std::size_t slash = path.rfind('/');
  const std::string folder = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  const int dir = ::open(folder.c_str(), O_RDONLY);
  if (dir >= 0) {
    ::fsync(dir);  // the rename itself; best effort
    ::close(dir);
  }
}

}  // namespace llc
