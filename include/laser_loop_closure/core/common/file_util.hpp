// Small helpers the core's savers and timed stages share.
#pragma once

#include <chrono>
#include <sstream>
#include <string>

namespace llc {

/// Writes `bytes` to `path` + ".tmp" and renames it over `path`, so that a crash during the
/// write leaves the old file intact. A `path` that exists and is no regular file (a device,
/// a pipe: /dev/stdout, /dev/full) is written in place, since renaming over it would replace
/// it. Throws std::runtime_error naming the file and the system's reason (a full disk, a
/// missing folder, no permission) on any failure, so no short or empty file passes for a result.
void writeFileAtomically(const std::string& path, const std::string& bytes);

/// A text file written as a whole: stream into it, then commit(), which writes it through
/// writeFileAtomically. Nothing reaches the disk before commit(); without it nothing does.
class AtomicTextFile : public std::ostringstream {
 public:
  explicit AtomicTextFile(std::string path) : path_(std::move(path)) {}
  AtomicTextFile(AtomicTextFile&& other) noexcept
      : std::ostringstream(std::move(other)), path_(std::move(other.path_)) {}
  /// Throws std::runtime_error (see writeFileAtomically).
  void commit() const { writeFileAtomically(path_, str()); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// Why `path` cannot be written as a file (its folder missing or not writable, the path a
/// folder), or "" when it can. Checks only; creates nothing. For checking outputs before a
/// long run starts.
[[nodiscard]] std::string whyNotWritable(const std::string& path);

/// Wall-clock seconds since `start`.
inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace llc
