#include "laser_loop_closure/ros/io/tf_listener.hpp"

#include <tf2/exceptions.h>

#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

TfListener::TfListener(tf2_ros::Buffer& buffer, ros::NodeHandle nh, double jump_back)
    : buffer_(buffer), jump_back_(jump_back) {
  nh.setCallbackQueue(&queue_);
  tf_sub_ = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100, [this](const ros::MessageEvent<const tf2_msgs::TFMessage>& e) { onTf(e, false); });
  static_sub_ = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100, [this](const ros::MessageEvent<const tf2_msgs::TFMessage>& e) { onTf(e, true); });
  // One thread: the messages of one publisher are taken in the order they were sent.
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

TfListener::~TfListener() {
  spinner_->stop();
  tf_sub_.shutdown();
  static_sub_.shutdown();
}

void TfListener::onTf(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static) {
  const tf2_msgs::TFMessage& msg = *event.getConstMessage();
  const std::string authority = event.getPublisherName();
  if (!is_static) {
    for (const auto& t : msg.transforms) {
      const auto found = newest_.find({tfFrame(t.header.frame_id), tfFrame(t.child_frame_id)});
      if (found == newest_.end() || t.header.stamp + ros::Duration(jump_back_) >= found->second) continue;
      ROS_WARN("tf stamps of %s -> %s jumped back %.2f s (a looped bag or a reset clock): tf history cleared",
               found->first.first.c_str(), found->first.second.c_str(), (found->second - t.header.stamp).toSec());
      buffer_.clear();  // dynamic transforms only: tf2 keeps the static ones
      newest_.clear();
      ++clears_;
      break;
    }
  }
  for (const auto& t : msg.transforms) {
    try {
      buffer_.setTransform(t, authority, is_static);
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(5.0, "tf: transform %s -> %s refused: %s", t.header.frame_id.c_str(), t.child_frame_id.c_str(), e.what());
    }
    if (!is_static) {
      ros::Time& newest = newest_[{tfFrame(t.header.frame_id), tfFrame(t.child_frame_id)}];
      if (t.header.stamp > newest) newest = t.header.stamp;
    }
  }
}

}  // namespace llc_ros
