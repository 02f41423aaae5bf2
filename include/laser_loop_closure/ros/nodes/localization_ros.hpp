// The localization nodelet's object (issue 63): merged scans in, the robot found on a saved map
// with no initial pose (llc::Localizer: the same front end, detector and aligner as mapping).
// Out: map -> odom once fixed (REP-105), /pose with covariance while localized, the saved map
// on /map, and a latched ~status (localized or lost, the fit) with diagnostics. ~relocalize
// forces a search of the whole map; /initialpose narrows the next search to the map near it.
// The saved session is only read.
//
// Threads, as loop_closure's: ScanReceiver gives each scan its wheel odometry and queues it in
// a bounded backlog; one worker thread owns the Localizer and empties the backlog through it.
// Hints and forced searches are posted to the worker as tasks run between two scans; the tf
// timer and diagnostics read what the worker last published. No callback waits on the clock.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "laser_loop_closure/LocalizationStatus.h"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/scan_backlog.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/ros/io/callback_thread.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/ros/io/tf_listener.hpp"
#include "laser_loop_closure/ros/nodes/localization_options.hpp"
#include "laser_loop_closure/ros/nodes/scan_receiver.hpp"
#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"

namespace llc_ros {

class LocalizationRos {
 public:
  /// Loads the model and the session (map_session), publishes the session's map latched on
  /// map; subscribes scan360 and initialpose; publishes pose and ~status; serves ~relocalize.
  /// Throws std::runtime_error on bad parameters, an unreadable model or session.
  LocalizationRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// Stops the timers, the receiver and the worker before any member goes.
  ~LocalizationRos();
  LocalizationRos(const LocalizationRos&) = delete;
  LocalizationRos& operator=(const LocalizationRos&) = delete;

 private:
  /// What the worker tells the other threads, published after every scan and task.
  struct WorkerState {
    laser_loop_closure::LocalizationStatus status;
    llc::LocalizerCounters counters;
    std::size_t malformed = 0;
    std::string last_problem;
    bool has_map_to_odom = false;  ///< from the first fix on
    llc::Pose2 map_to_odom;
    double last_search_seconds = 0.0;  ///< of the newest keyframe searched while lost
  };

  void work();
  void processScan(const PendingScan& pending);
  /// The status after this step to the worker's state, published on ~status when it is due.
  void updateStatus(const llc::LocalizationStep& step, const std_msgs::Header& scan_header);
  /// ~status with the localizer's counters (worker thread).
  void sendStatus();
  /// After a forced search or a hint: ~status says lost, and why (worker thread).
  void searchAgain(const std::string& why);
  /// The worker's state to the other threads (worker thread).
  void publishState();
  /// Without wheels: odom_frame -> the scan's frame from the localizer's scan matching.
  void publishOdometry(const llc::LocalizationStep& step, const std_msgs::Header& scan_header);
  void publishTransform();
  void onInitialPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg);
  bool relocalize(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  LocalizationNodeOptions options_;
  llc::SystemOptions system_;
  tf2_ros::Buffer tf_buffer_;
  TfListener tf_listener_;
  // Each CallbackThread is declared before the handles registered on its queue: members go in
  // reverse order, and a handle that goes after its queue locks a destroyed mutex (unloading the
  // nodelet then aborted the whole manager: localize_kidnap.test loads and unloads each nodelet).
  CallbackThread service_thread_;    ///< ~relocalize and /initialpose: answered while the worker searches
  CallbackThread transform_thread_;  ///< map -> odom broadcasts
  ros::Publisher pose_pub_, map_pub_, status_pub_;
  ros::Subscriber initial_pose_sub_;
  ros::ServiceServer relocalize_srv_;
  ros::Timer tf_timer_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Time last_tf_time_;
  diagnostic_updater::Updater diagnostics_;
  ros::WallTimer diagnostics_timer_;
  CallbackTiming scan_latency_;  ///< a scan's arrival to the end of its processing (queue + localizer)

  // The worker's own: nothing else touches them.
  std::unique_ptr<llc::Localizer> localizer_;
  WorkerState state_;
  std::string last_published_state_;  ///< of ~status ("" before the first)
  tf2_ros::TransformBroadcaster odometry_broadcaster_;
  ros::Time last_odometry_stamp_;

  mutable std::mutex state_mutex_;  ///< guards published_
  WorkerState published_;

  std::unique_ptr<WheelOdometryReader> wheels_;
  std::unique_ptr<llc::ScanBacklog<PendingScan>> backlog_;
  std::unique_ptr<ScanReceiver> receiver_;
  std::thread worker_;
};

}  // namespace llc_ros
