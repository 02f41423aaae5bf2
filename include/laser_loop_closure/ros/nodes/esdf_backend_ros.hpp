// The esdf_backend nodelet's object: Keyframe and LoopClosure messages from a front end go into
// the shared back end (llc::SlamBackEnd: ESDF on CHOLMOD, chi-square gate on loops); it
// publishes the path, the newest pose with its covariance, map -> odom on /tf (REP-105), a
// latched occupancy grid, a point-cloud map, the graph as markers, and its health.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/PackedKeyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/LoadSession.h"
#include "laser_loop_closure/NearbyKeyframes.h"
#include "laser_loop_closure/PlaceCheck.h"
#include "laser_loop_closure/SaveMap.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/ros/io/callback_thread.hpp"
#include "laser_loop_closure/ros/io/map_updates.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"

namespace llc_ros {

struct EsdfBackendNodeOptions {
  std::string map_frame = "map";       ///< frame of the path, the map and the markers
  std::string odom_frame = "odom";     ///< child of map_frame in the published transform
  bool publish_tf = true;              ///< publish map -> odom (needs keyframes with an odometry pose: wheels, or loop_closure's publish_odometry_tf)
  double transform_tolerance = 0.1;    ///< s the published transform is dated into the future
  double tf_publish_period = 0.05;     ///< s between map -> odom broadcasts
  double map_publish_period = 2.0;     ///< s of wall time between updates of /map, the cloud and the markers (when changed)
  /// At most this share of one core updates /map, the cloud and the markers: after an update of
  /// t s the next waits max(map_publish_period, t / map_cpu_share) s (a large map comes less often).
  double map_cpu_share = 0.25;
  /// false (as costmap_2d's map and updates): a new subscriber gets /map whole at the next
  /// update (0.1 s), and no serialised copy of the whole grid (1 byte per cell) is kept; but a
  /// second subscriber in a process that already has one waits for the next whole map. true: a
  /// new subscriber first gets the last whole map, which the parts sent since may have outdated
  bool latch_map = false;
  double cloud_voxel_size = 0.05;      ///< m; the point-cloud map keeps one point per cube this size (0: all)
  /// m; the keyframes' scans are kept for the map and sessions packed, each point within half
  /// this step (and half of step / 50 m in bearing) of where it was: ~1.2 kB per 722 beams
  /// against 3.1 exact (0: kept exact)
  double map_scan_step = 0.0005;
  std::string map_path = "llc_map";    ///< default file stem of ~save_map (relative: to the working directory)
  std::string session_path = "llc_session.llcsession";  ///< default file of ~save_session and ~load_session
  int session_part_keyframes = 100;    ///< keyframes per message of a restored session on topic session
  int max_pending_loops = 1000;        ///< loops held until their keyframes arrive
  int queue_size = 1000;               ///< keyframes and loops kept while the back end is busy
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitEsdfBackendParameters(EsdfBackendNodeOptions& o, Visit&& visit) {
  visit("map_frame", o.map_frame);
  visit("odom_frame", o.odom_frame);
  visit("publish_tf", o.publish_tf);
  visit("transform_tolerance", o.transform_tolerance);
  visit("tf_publish_period", o.tf_publish_period);
  visit("map_publish_period", o.map_publish_period);
  visit("map_cpu_share", o.map_cpu_share);
  visit("latch_map", o.latch_map);
  visit("cloud_voxel_size", o.cloud_voxel_size);
  visit("map_scan_step", o.map_scan_step);
  visit("map_path", o.map_path);
  visit("session_path", o.session_path);
  visit("session_part_keyframes", o.session_part_keyframes);
  visit("max_pending_loops", o.max_pending_loops);
  visit("queue_size", o.queue_size);
}

class EsdfBackendRos {
 public:
  /// Subscribes keyframes and loop_closures; publishes path, pose, map (latch_map), map_updates, map_cloud,
  /// graph_markers, ~loop_records and session (in parts, after a load); serves ~save_map,
  /// ~save_session and ~load_session. Throws std::runtime_error on bad parameters.
  EsdfBackendRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~EsdfBackendRos();
  EsdfBackendRos(const EsdfBackendRos&) = delete;
  EsdfBackendRos& operator=(const EsdfBackendRos&) = delete;

 private:
  void onKeyframe(const laser_loop_closure::Keyframe::ConstPtr& msg);
  /// Unpacked into a Keyframe and taken as one; refused (counted) when its scan does not unpack.
  void onPackedKeyframe(const laser_loop_closure::PackedKeyframe::ConstPtr& msg);
  /// Takes the held keyframes whose loops_before have all come (under mutex_). A keyframe held
  /// behind more than kMostHeldKeyframes others is taken anyway (its loops were lost, or the
  /// front end restarted): the count starts again from it.
  void takeHeldKeyframes();
  void takeKeyframe(const laser_loop_closure::Keyframe& msg);
  /// loop_closure's place gate: answers from the state llc slam would have (waits for it, bounded).
  bool placeCheck(laser_loop_closure::PlaceCheck::Request& request, laser_loop_closure::PlaceCheck::Response& response);
  bool nearbyKeyframes(laser_loop_closure::NearbyKeyframes::Request& request,
                       laser_loop_closure::NearbyKeyframes::Response& response);
  /// A front end's question (~place_check, ~nearby_keyframes), answered from the state it names:
  /// under mutex_, counts it in `asked`, waits (wall time, bounded) until the back end holds
  /// `keyframes` keyframes and has taken `loops` loop messages, then runs `answer` and sets
  /// response.answered; else (or when `answer` throws) counts it in `unanswered` and says why
  /// in response.message.
  template <class Response, class Answer>
  void answerFromFrontEndState(std::size_t keyframes, std::uint64_t loops, std::size_t& asked, std::size_t& unanswered,
                               Response& response, Answer&& answer);
  void onLoop(const laser_loop_closure::LoopClosure::ConstPtr& msg);
  void takeLoop(const laser_loop_closure::LoopClosure::ConstPtr& msg);
  /// Applies one loop whose keyframes exist; publishes its record.
  void applyLoop(const laser_loop_closure::LoopClosure& msg);
  /// Publishes path and pose, and hands map -> odom to the transform thread; called whenever
  /// the poses change.
  void publishPoses();
  void publishMap();
  void publishTransform();
  bool saveMap(laser_loop_closure::SaveMap::Request& request, laser_loop_closure::SaveMap::Response& response);
  bool saveSession(laser_loop_closure::SaveSession::Request& request, laser_loop_closure::SaveSession::Response& response);
  bool loadSession(laser_loop_closure::LoadSession::Request& request, laser_loop_closure::LoadSession::Response& response);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  std_msgs::Header mapHeader() const;

  EsdfBackendNodeOptions options_;
  llc::SystemOptions system_;
  std::unique_ptr<llc::SlamBackEnd> back_;
  // Each CallbackThread is declared before the handles registered on its queue: members go in
  // reverse order, and a handle that goes after its queue locks a destroyed mutex (unloading the
  // nodelet then aborted the whole manager: localize_kidnap.test loads and unloads each nodelet).
  // The place check has its own queue and thread: it waits for keyframes the main queue brings.
  CallbackThread place_thread_;
  // The services have their own queue and thread: they answer while keyframes queue up and
  // while the clock stands still (a bag ended or paused).
  CallbackThread service_thread_;
  // /map, the cloud and the markers are rebuilt on their own queue and thread (map_timer_).
  CallbackThread map_thread_;
  // map -> odom is broadcast from its own thread and queue, so that a map rebuild (which holds
  // mutex_ and the nodelet's queue for a while) never leaves tf users without it.
  CallbackThread transform_thread_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Subscriber keyframe_sub_, packed_keyframe_sub_, loop_sub_;
  ros::Publisher path_pub_, pose_pub_, cloud_pub_, marker_pub_, record_pub_, session_pub_;
  ros::ServiceServer save_map_srv_, save_session_srv_, load_session_srv_, place_check_srv_, nearby_srv_;
  ros::Timer tf_timer_;  // on transform_thread_
  // Wall time: the last keyframes of a bag reach /map, and the health is told, after the clock stopped.
  ros::WallTimer map_timer_, diagnostics_timer_;
  diagnostic_updater::Updater diagnostics_;

  std::mutex mutex_;
  std::condition_variable state_changed_;  ///< a keyframe or a loop was taken (with mutex_)
  std::deque<laser_loop_closure::LoopClosure> pending_loops_;
  /// Keyframes whose loops_before have not all come yet: taken in the order llc slam takes them.
  std::deque<laser_loop_closure::Keyframe::ConstPtr> held_keyframes_;
  static constexpr std::size_t kMostHeldKeyframes = 3;
  std::uint64_t loops_taken_ = 0;  ///< LoopClosure messages received (applied, pending or refused)
  std::size_t loop_order_resyncs_ = 0, place_checks_ = 0, place_checks_unanswered_ = 0;
  std::size_t nearby_asked_ = 0, nearby_unanswered_ = 0;
  std::vector<llc::LoopRecord> refused_by_alignment_;  ///< shown in grey; never applied
  /// Of each keyframe, from its message, for sessions: in single precision, as the front end
  /// stores and classifies them (llc slam's sessions hold the same values).
  std::vector<std::vector<float>> features_;
  llc::KeyframeRobots robots_;                         ///< who made each keyframe (a loaded session's, then this run's)
  /// Each keyframe's scan, shared with the map rebuild, which runs outside mutex_.
  std::vector<std::shared_ptr<const llc::CompactScan>> map_scans_;
  std::mutex map_building_;  ///< one rebuild at a time
  bool map_dirty_ = false;

  std::mutex transform_mutex_;
  llc::Pose2 map_to_odom_;       ///< guarded by transform_mutex_
  bool has_map_to_odom_ = false;  ///< guarded by transform_mutex_: the newest keyframe has wheel odometry
  ros::Time last_tf_time_;        ///< the transform thread's own
  std::size_t refused_keyframes_ = 0, dropped_loops_ = 0;
  /// Keyframes refused since the last one taken: the graph is stopped while above 0 (a load's
  /// race with the front end refuses a few, then mapping goes on and this is 0 again).
  std::size_t refused_in_a_row_ = 0;
  /// /map's update (drawing what changed and sending it): the last, the longest sent by parts,
  /// the longest sent whole (on growth or for a new subscriber: its cost is the map's area)
  double last_map_seconds_ = 0.0, longest_map_parts_seconds_ = 0.0, longest_whole_map_seconds_ = 0.0;
  bool last_map_whole_ = false;
  std::size_t whole_maps_sent_ = 0, map_keyframes_waiting_ = 0, map_bytes_ = 0;
  std::unique_ptr<MapUpdatePublisher> map_updates_;  ///< used under map_building_
  std::chrono::steady_clock::time_point next_map_allowed_;  ///< map_cpu_share's throttle (under map_building_)
  std::chrono::steady_clock::time_point last_map_update_;   ///< map_publish_period's (under mutex_)
  std::array<std::size_t, llc::kLoopRefusalKinds> refusals_{};  ///< loops the back end refused, by llc::LoopRefusal
  std::uint32_t session_loads_ = 0;                           ///< ~load_session calls that restored a session
  CallbackTiming callback_timing_;  ///< onKeyframe and onLoop (lock wait and the ESDF update included)
  std::string last_problem_;
};

}  // namespace llc_ros
