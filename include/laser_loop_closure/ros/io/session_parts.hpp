// The parts of a restored session put back together: the back end sends a session on topic
// session in messages of at most session_part_keyframes keyframes (one message of a long
// session would be tens of MB); the front end restores it once every part of one load came,
// in order. A part out of order, from an interrupted load, or with a malformed keyframe refuses
// that load (the parts so far are dropped; the running map is not touched).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc_ros {

struct AssembledSession {
  std::vector<llc::Keyframe> keyframes;
  std::vector<std::vector<double>> features;  ///< one vector per keyframe
};

class SessionAssembler {
 public:
  enum class Status {
    kIncomplete,  ///< more parts to come
    kComplete,    ///< *session holds the whole session
    kRefused,     ///< *error says why; the parts so far are dropped
  };
  Status add(const laser_loop_closure::Session& part, AssembledSession* session, std::string* error);

 private:
  std::uint32_t load_ = 0, next_part_ = 0;
  AssembledSession parts_;
};

}  // namespace llc_ros
