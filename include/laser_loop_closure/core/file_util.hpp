// Small helpers the core's savers and timed stages share.
#pragma once

#include <chrono>
#include <string>

namespace llc {

/// Writes `bytes` to `path` + ".tmp" and renames it over `path`, so that a crash during the
/// write leaves the old file intact. Throws std::runtime_error naming the file that failed.
void writeFileAtomically(const std::string& path, const std::string& bytes);

/// Wall-clock seconds since `start`.
inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace llc
