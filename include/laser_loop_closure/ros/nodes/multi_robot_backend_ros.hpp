// The multi_robot_backend nodelet's object (issue 64): one back end for several robots, each
// running its own scan_merger and loop_closure in its own namespace, possibly on its own
// computer. Only their Keyframe and LoopClosure messages cross the network. It runs the same
// llc::MultiRobotSlam as `llc slam --log A --log B`: robots join the first one's map once
// several of their keyframes agree with it (no relative prior), and it publishes one /map,
// map -> <robot>/odom for each joined robot, a path per robot and the graph with cross-robot
// loops in their own colour. A robot that stops sending, or starts late, stalls no other.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/PackedKeyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/NearbyKeyframes.h"
#include "laser_loop_closure/PlaceCheck.h"
#include "laser_loop_closure/SaveMap.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/core/slam/keyframe_inbox.hpp"
#include "laser_loop_closure/core/slam/multi_robot_slam.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/ros/io/callback_thread.hpp"
#include "laser_loop_closure/ros/io/map_updates.hpp"

namespace llc_ros {

struct MultiRobotBackendNodeOptions {
  std::string robots = "";             ///< the robots' namespaces, separated by spaces; the first one's frame is the map's
  std::string model_path = "";         ///< classifier model (YAML) of the cross-robot search; empty: config/classifier.yaml
  /// A saved session (yesterday's map of the fleet) every robot joins, its frame the map's; "":
  /// none, the first robot's frame is the map's.
  std::string map_session = "";
  std::string map_frame = "map";       ///< frame of the map, the joined robots' paths and the markers
  std::string odom_frame = "odom";     ///< each robot's odometry frame is <robot>/odom_frame (map -> it published once joined)
  bool publish_tf = true;              ///< publish map -> <robot>/odom for every joined robot
  double transform_tolerance = 0.1;    ///< s the published transforms are dated into the future
  double tf_publish_period = 0.05;     ///< s between map -> odom broadcasts
  double map_publish_period = 2.0;     ///< s of wall time between updates of /map and the markers (when changed)
  bool latch_map = false;              ///< latch /map (as esdf_backend's latch_map)
  double map_scan_step = 0.0005;       ///< m; the map's scans kept packed (as esdf_backend's map_scan_step; 0: exact)
  double answer_timeout = 2.0;         ///< s of wall time a robot's place check waits for the state it names
  /// s of wall time keyframes that came after a gap wait for the missing ones, asked again of the
  /// robot's front end (<robot>/resend_request), before the gap is bridged by its odometry.
  double resend_wait = 10.0;
  std::string map_path = "llc_fleet_map";  ///< default file stem of ~save_map (relative: to the working directory)
  std::string session_path = "llc_fleet.llcsession";  ///< default file of ~save_session
  int queue_size = 1000;               ///< keyframes and loops kept per robot while the back end is busy
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitMultiRobotBackendParameters(MultiRobotBackendNodeOptions& o, Visit&& visit) {
  visit("robots", o.robots);
  visit("model_path", o.model_path);
  visit("map_session", o.map_session);
  visit("map_frame", o.map_frame);
  visit("odom_frame", o.odom_frame);
  visit("publish_tf", o.publish_tf);
  visit("transform_tolerance", o.transform_tolerance);
  visit("tf_publish_period", o.tf_publish_period);
  visit("map_publish_period", o.map_publish_period);
  visit("latch_map", o.latch_map);
  visit("map_scan_step", o.map_scan_step);
  visit("answer_timeout", o.answer_timeout);
  visit("resend_wait", o.resend_wait);
  visit("map_path", o.map_path);
  visit("session_path", o.session_path);
  visit("queue_size", o.queue_size);
}

/// The robots' namespaces in `robots` (separated by spaces or commas, each a valid ROS name,
/// none twice); throws std::invalid_argument naming the fault.
std::vector<std::string> parseRobotNames(const std::string& robots);

class MultiRobotBackendRos {
 public:
  /// Subscribes <robot>/keyframes and <robot>/loop_closures of each robot; publishes map
  /// (latched), graph_markers (latched), <robot>/path, map -> <robot>/odom; serves
  /// ~<robot>/place_check and ~<robot>/nearby_keyframes (each robot's front end asks them of
  /// its own graph, as llc slam's robot pipelines do), ~save_session and ~save_map. Throws
  /// std::runtime_error on bad parameters or model.
  MultiRobotBackendRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~MultiRobotBackendRos();
  MultiRobotBackendRos(const MultiRobotBackendRos&) = delete;
  MultiRobotBackendRos& operator=(const MultiRobotBackendRos&) = delete;

 private:
  /// A keyframe message as it came and as read (read once, when it came).
  struct ArrivedKeyframe {
    laser_loop_closure::Keyframe::ConstPtr msg;
    llc::Keyframe keyframe;
    llc::OdometryStep step;
  };
  using Inbox = llc::KeyframeInbox<std::shared_ptr<const ArrivedKeyframe>>;

  /// One robot as this node meets it: its messages in order (inbox), its loops waiting for
  /// their keyframes, what crossed the network. A front end that restarts starts a new run in
  /// the inbox (a new chain of the same robot).
  struct Robot {
    std::string name;
    std::string odom_frame;
    ros::Subscriber keyframe_sub, packed_keyframe_sub, loop_sub;
    ros::Publisher path_pub, resend_pub;
    ros::ServiceServer place_check_srv, nearby_srv;
    std::unique_ptr<Inbox> inbox;
    std::deque<laser_loop_closure::LoopClosure> pending_loops;  ///< waiting for their keyframes
    bool has_last_wheels = false;       ///< the newest keyframe taken had an odometry pose
    llc::Pose2 last_wheels;
    std::size_t keyframes_refused = 0, loops_dropped = 0;
    std::uint64_t bytes = 0;            ///< serialised size of every message received, service request and answer
    std::uint64_t service_bytes = 0;    ///< of which place checks and nearby keyframes (requests and answers)
    std::uint64_t loop_bytes = 0;       ///< of which LoopClosure messages
    ros::WallTime first_message, last_message;
  };

  /// wire_bytes: the size it crossed the network in (0: the message's own).
  void onKeyframe(std::size_t robot, const laser_loop_closure::Keyframe::ConstPtr& msg, std::uint32_t wire_bytes = 0);
  void onPackedKeyframe(std::size_t robot, const laser_loop_closure::PackedKeyframe::ConstPtr& msg);
  void onLoop(std::size_t robot, const laser_loop_closure::LoopClosure::ConstPtr& msg);
  void countBytes(Robot& robot, std::uint32_t bytes);
  void countServiceBytes(std::size_t robot, std::uint32_t bytes);  ///< takes the lock
  /// Under mutex_: the keyframes the robot's inbox hands out now, taken in order; asks the robot
  /// for missing ones when the inbox says so.
  void takeHeldKeyframes(std::size_t robot);
  void takeKeyframe(std::size_t robot, const Inbox::Taken& taken);
  /// Under mutex_: the loop into the robot's graph (and the map's) if both its keyframes came;
  /// returns false when one has not come yet.
  bool takeLoop(std::size_t robot, const laser_loop_closure::LoopClosure& msg);
  bool placeCheck(std::size_t robot, laser_loop_closure::PlaceCheck::Request& request,
                  laser_loop_closure::PlaceCheck::Response& response);
  bool nearbyKeyframes(std::size_t robot, laser_loop_closure::NearbyKeyframes::Request& request,
                       laser_loop_closure::NearbyKeyframes::Response& response);
  /// Waits (answer_timeout, wall) under `lock` until the robot's graph holds `keyframes` of its
  /// front end's keyframes and took `loops` loop messages; "" or why not.
  std::string waitForRobotState(std::unique_lock<std::mutex>& lock, std::size_t robot, std::size_t keyframes,
                                std::uint64_t loops);
  void publishPaths();
  void publishMap();
  void publishTransforms();
  /// Under mutex_: map -> <robot>/odom of each joined robot from its newest keyframe.
  void updateTransforms();
  bool saveSession(laser_loop_closure::SaveSession::Request& request, laser_loop_closure::SaveSession::Response& response);
  bool saveMap(laser_loop_closure::SaveMap::Request& request, laser_loop_closure::SaveMap::Response& response);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  /// The MultiRobotSlam robot of robot `robot` of robots_ (1 later with a saved map, its robot 0).
  std::size_t slot(std::size_t robot) const { return robot + slot_offset_; }

  MultiRobotBackendNodeOptions options_;
  llc::SystemOptions system_;
  std::size_t slot_offset_ = 0;  ///< 1 with a saved map (map_session)
  std::unique_ptr<llc::MultiRobotSlam> slam_;
  std::unique_ptr<llc::ScanOdometry> odometry_model_;  ///< the covariance of a step bridged by wheels over lost keyframes
  // Threads before the handles registered on their queues (see esdf_backend_ros.hpp).
  CallbackThread service_thread_, map_thread_, transform_thread_;
  std::vector<Robot> robots_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Publisher marker_pub_;
  std::unique_ptr<MapUpdatePublisher> map_updates_;  ///< used on map_thread_ only
  ros::ServiceServer save_session_srv_, save_map_srv_;
  ros::Timer tf_timer_;
  ros::WallTimer map_timer_, diagnostics_timer_;
  ros::WallTimer gap_timer_;  ///< takes held keyframes whose gap was not filled in time (no message may come)
  diagnostic_updater::Updater diagnostics_;

  std::mutex mutex_;
  std::condition_variable state_changed_;
  bool map_dirty_ = false;
  std::mutex transform_mutex_;
  std::vector<std::pair<std::string, llc::Pose2>> map_to_odom_;
  /// Each map keyframe's scan, shared with the map rebuild, which runs outside mutex_.
  std::vector<std::shared_ptr<const llc::CompactScan>> map_scans_;  ///< per joined robot with an odometry pose (transform_mutex_)
  ros::Time last_tf_time_;
  std::string last_problem_;
};

}  // namespace llc_ros
