// The loop_closure nodelet's object: merged scans in; the shared front end (llc::SlamFrontEnd:
// keyframes, ICP odometry seeded by wheel odometry from tf, the classifier against every older
// keyframe with no pose prior, CRF-match/ICP/shape validation) out as Keyframe and
// LoopClosure messages for a back end.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "laser_loop_closure/Scan360.h"
#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/TrainClassifier.h"
#include "laser_loop_closure/core/slam_front_end.hpp"
#include "laser_loop_closure/core/slam_parameters.hpp"

namespace llc_ros {

struct LoopClosureNodeOptions {
  std::string model_path;            ///< classifier model (YAML); empty: the package's config/classifier.yaml
  std::string odom_frame = "odom";   ///< wheel odometry frame (tf odom_frame -> scan's base frame)
  bool use_wheel_odometry = true;    ///< seed scan matching by tf; a scan without it is skipped
  /// Without wheel odometry: broadcast odom_frame -> the scan's frame from scan matching, and
  /// give each keyframe its pose in odom_frame, so that the back end publishes map -> odom_frame.
  bool publish_odometry_tf = false;
  double tf_timeout = 0.1;           ///< s to wait for the odometry transform at a scan's stamp
  int queue_size = 200;              ///< merged scans kept while loop detection runs
  std::string trained_model_path = "llc_classifier.yaml";  ///< default file of ~train_classifier (relative: to the working directory)
  std::string validate() const;
};

template <class Visit>
void visitLoopClosureParameters(LoopClosureNodeOptions& o, Visit&& visit) {
  visit("model_path", o.model_path);
  visit("odom_frame", o.odom_frame);
  visit("use_wheel_odometry", o.use_wheel_odometry);
  visit("publish_odometry_tf", o.publish_odometry_tf);
  visit("tf_timeout", o.tf_timeout);
  visit("queue_size", o.queue_size);
  visit("trained_model_path", o.trained_model_path);
}

class LoopClosureRos {
 public:
  /// Subscribes scan360, path (the back end's optimised keyframe poses, for training) and
  /// session (keyframes of a session the back end loaded);
  /// publishes keyframes and loop_closures (names relative to nh); serves ~train_classifier.
  /// Throws std::runtime_error on bad parameters or an unreadable model.
  LoopClosureRos(ros::NodeHandle nh, ros::NodeHandle private_nh);

 private:
  void onScan(const laser_loop_closure::Scan360::ConstPtr& msg);
  /// publish_odometry_tf: broadcasts odom_frame -> the scan's frame for this scan and, for a
  /// keyframe, gives it its pose in odom_frame (as has_wheel_odometry / wheel_odometry).
  void publishOdometry(const llc::FrontEndStep& step, const std_msgs::Header& scan_header, llc::Keyframe* keyframe);
  void onPath(const nav_msgs::Path::ConstPtr& msg);
  /// A session the back end restored: the keyframes (and their features) replace ours.
  void onSession(const laser_loop_closure::Session::ConstPtr& msg);
  /// Trains outside the scan lock (scans keep flowing); swaps the model in under it.
  bool trainClassifier(laser_loop_closure::TrainClassifier::Request& request,
                       laser_loop_closure::TrainClassifier::Response& response);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  LoopClosureNodeOptions options_;
  llc::SystemOptions system_;
  std::unique_ptr<llc::SlamFrontEnd> front_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber scan_sub_, path_sub_, session_sub_;
  ros::ServiceServer train_srv_;
  ros::Publisher keyframe_pub_, loop_pub_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;

  std::mutex mutex_;     ///< guards everything below and front_
  std::mutex training_;  ///< one training at a time
  std::size_t scans_received_ = 0, no_odometry_ = 0, malformed_ = 0;
  std::vector<llc::Pose2> optimised_poses_;  ///< from path: keyframe k at index k
  bool keyframes_full_circle_ = true;        ///< every keyframe scan covers 360 degrees
  std::size_t models_trained_ = 0, models_swapped_ = 0;
  std::string model_path_;  ///< of the running model
  // Scan-matching odometry (publish_odometry_tf): the newest keyframe's pose in odom_frame.
  tf2_ros::TransformBroadcaster odometry_broadcaster_;
  llc::Pose2 keyframe_in_odometry_;
  bool has_keyframe_in_odometry_ = false;
  ros::Time last_odometry_stamp_;
  std::string last_problem_;
};

}  // namespace llc_ros
