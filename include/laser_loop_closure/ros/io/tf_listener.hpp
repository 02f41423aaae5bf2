// A tf listener that survives a looped bag or a reset clock. tf2_ros::TransformListener clears
// its buffer when ros::Time::now() goes back, but /clock and /tf come on separate connections:
// a transform of the old pass taken in after that clear makes the buffer refuse every transform
// of the new pass as "TF_OLD_DATA" for good (seen with a test player and with `rosbag play -l`).
// This one judges by the transforms' own stamps, on the one thread that fills the buffer: when
// a (parent, child) pair's stamp goes back by more than jump_back seconds, the buffer's dynamic
// transforms are cleared and the new pass starts from this message (static mounts are kept).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include <atomic>
#include <map>
#include <memory>
#include <string>
#include <utility>

namespace llc_ros {

class TfListener {
 public:
  /// Subscribes /tf and /tf_static (through nh, so remappings apply) on its own queue and thread.
  TfListener(tf2_ros::Buffer& buffer, ros::NodeHandle nh, double jump_back = 1.0);
  ~TfListener();
  TfListener(const TfListener&) = delete;
  TfListener& operator=(const TfListener&) = delete;
  /// Times the stamps jumped back and the buffer was cleared.
  std::size_t clears() const { return clears_; }

 private:
  void onTf(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static);

  tf2_ros::Buffer& buffer_;
  double jump_back_;
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::Subscriber tf_sub_, static_sub_;
  std::map<std::pair<std::string, std::string>, ros::Time> newest_;  ///< per (parent, child); spinner thread only
  std::atomic<std::size_t> clears_{0};
};

}  // namespace llc_ros
