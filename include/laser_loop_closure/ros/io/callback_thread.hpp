// One callback queue served by its own thread: what a nodelet gives a timer or a service that
// must not wait behind its main queue (a map rebuild, a service that answers while keyframes
// queue up, a transform broadcast). handle() before registering, start() after, stop() in the
// owner's destructor before the members the callbacks read go. Declare it before the handles
// registered on it: a handle destroyed after its queue locks a destroyed mutex (the manager aborts).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <memory>

namespace llc_ros {

class CallbackThread {
 public:
  /// A node handle like `base` whose callbacks go to this thread's queue.
  ros::NodeHandle handle(const ros::NodeHandle& base) {
    ros::NodeHandle nh(base);
    nh.setCallbackQueue(&queue_);
    return nh;
  }
  void start() {
    spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
    spinner_->start();
  }
  void stop() {
    if (spinner_) spinner_->stop();
  }
  ~CallbackThread() { stop(); }

 private:
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
};

}  // namespace llc_ros
