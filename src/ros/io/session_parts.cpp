#include "laser_loop_closure/ros/io/session_parts.hpp"

#include <utility>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace llc_ros {

SessionAssembler::Status SessionAssembler::add(const laser_loop_closure::Session& msg, AssembledSession* session,
                                               std::string* error) {
  if (msg.part == 0) load_ = msg.load, next_part_ = 0, parts_ = AssembledSession{};
  error->clear();
  if (msg.load != load_ || msg.part != next_part_ || msg.first_keyframe != parts_.keyframes.size())
    *error = "part " + std::to_string(msg.part) + " of load " + std::to_string(msg.load) + " came without the parts before it";
  llc::Pose2 motion;
  Eigen::Matrix3d covariance;
  for (std::size_t k = 0; k < msg.keyframes.size() && error->empty(); ++k) {
    parts_.keyframes.emplace_back();
    if (!fromKeyframeMsg(msg.keyframes[k], &parts_.keyframes.back(), &motion, &covariance, error))
      *error = "keyframe " + std::to_string(msg.first_keyframe + k) + ": " + *error;
    parts_.features.push_back(msg.keyframes[k].features);
  }
  if (error->empty() && msg.part + 1 == msg.parts && parts_.keyframes.size() != msg.total_keyframes)
    *error = std::to_string(parts_.keyframes.size()) + " keyframes came, the session has " + std::to_string(msg.total_keyframes);
  if (error->empty() && msg.part + 1 < msg.parts) {
    ++next_part_;
    return Status::kIncomplete;
  }
  *session = std::move(parts_);
  parts_ = AssembledSession{};
  load_ = 0, next_part_ = 0;
  return error->empty() ? Status::kComplete : Status::kRefused;
}

}  // namespace llc_ros
