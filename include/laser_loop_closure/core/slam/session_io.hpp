// A SLAM session on disk: every keyframe (scan, stamp, wheel odometry), its feature vector,
// the optimised poses, every constraint of the ESDF (odometry and loops, with information)
// and every loop the back end met. Binary, versioned, checksummed, written to a temporary
// file and renamed so a crash during a save leaves the previous file whole.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

class SlamBackEnd;

/// Version 2 added each loop record's by_consensus; version-1 files still load (false).
/// Version 3 added each loop's and loop record's refusal as a code (LoopRefusal); older files
/// kept it only in the reason's text, which is read once for them at load.
/// Version 4 added each keyframe's robot (SlamSession::robots); older files load as robot 0's.
constexpr std::uint32_t kSessionVersion = 4;
constexpr std::uint32_t kOldestSessionVersion = 1;

/// Why a session file was refused; what() names the file and the problem.
class SessionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws SessionError when the session is inconsistent or the file cannot be written.
void saveSession(const SlamSession& session, const std::string& path);
/// Refuses (SessionError) a missing file, another format or version, a truncated or
/// corrupted file (checksum), and a session that does not validate().
SlamSession loadSession(const std::string& path);

/// Who made each keyframe of a map that went on from a saved session: the session's robots
/// for its keyframes, then the run that goes on: the newest restored keyframe's robot when its
/// odometry goes on (continue_odometry: the same robot), else a new one (the largest + 1: a new
/// run). A map that restored nothing is robot 0's. So a session saved again keeps who was who.
struct KeyframeRobots {
  std::vector<std::uint32_t> restored;
  std::uint32_t current = 0;
  static KeyframeRobots afterRestore(const SlamSession& session, bool continue_odometry);
  /// Per keyframe of a map of `keyframes`: the restored ones', then `current`.
  std::vector<std::uint32_t> of(std::size_t keyframes) const;
};

/// The session of a running back end plus the front end's features of its keyframes (and who
/// made them, when given).
SlamSession sessionOf(const SlamBackEnd& back, const std::vector<std::vector<double>>& features,
                      const KeyframeRobots* robots = nullptr);

}  // namespace llc
