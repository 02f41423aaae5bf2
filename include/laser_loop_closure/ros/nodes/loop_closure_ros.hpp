// The loop_closure nodelet's object: merged scans in; the shared front end (llc::SlamFrontEnd:
// keyframes, ICP odometry seeded by wheel odometry from tf, the classifier against every older
// keyframe with no pose prior, CRF-match/ICP/shape validation) out as Keyframe and
// LoopClosure messages for a back end.
//
// Threads: no callback waits on the ROS clock (which stops when a bag ends or is paused). A
// scan waits for its odometry transform in a tf2_ros::MessageFilter (no thread blocked), takes
// its wheel-odometry pose as soon as tf has it, and joins a bounded backlog (llc::ScanBacklog)
// that one worker thread empties through the front end. ~train_classifier has its own callback
// queue and thread, so it answers while scans are processed and while the clock stands still.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <message_filters/subscriber.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_broadcaster.h>

#include <array>
#include <atomic>
#include <map>
#include <memory>
#include <chrono>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "laser_loop_closure/NearbyKeyframes.h"
#include "laser_loop_closure/PlaceCheck.h"
#include "laser_loop_closure/Scan360.h"
#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/TrainClassifier.h"
#include "laser_loop_closure/core/slam/scan_backlog.hpp"
#include "laser_loop_closure/core/slam/seq_reorder.hpp"
#include "laser_loop_closure/ros/io/callback_thread.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/ros/io/session_parts.hpp"
#include "laser_loop_closure/ros/io/tf_listener.hpp"
#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"
#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"

namespace llc_ros {

struct LoopClosureNodeOptions {
  std::string model_path;            ///< classifier model (YAML); empty: the package's config/classifier.yaml
  std::string odom_frame = "odom";   ///< wheel odometry frame (tf odom_frame -> scan's base frame)
  bool use_wheel_odometry = true;    ///< seed scan matching by tf; a scan without it is skipped
  /// Without wheel odometry: broadcast odom_frame -> the scan's frame from scan matching, and
  /// give each keyframe its pose in odom_frame, so that the back end publishes map -> odom_frame.
  bool publish_odometry_tf = false;
  /// With use_wheel_odometry: when this many scans came and not one got its odometry transform
  /// (a bag or robot with no odometry in tf), map without wheels from then on (those scans
  /// too) and broadcast odom_frame -> the scan's frame from scan matching, with one warning
  /// (0: wait for the wheels for ever).
  int wheel_odometry_wait_scans = 50;
  /// s added to each scan's stamp where its wheel odometry is looked up in tf, in [-1, 0]: a
  /// scanner whose stamps come d s after the wheels' (stamped on arrival) wants -d. With
  /// estimate_odometry_time_offset, only until the estimate has chosen.
  double odometry_time_offset = 0.0;
  /// Estimate odometry_time_offset from the drive (llc::OdometryTimeOffsetProbe: 0 to 3 scan
  /// periods back, chosen after 100 moving scan pairs whose candidates part in heading), and
  /// read the wheels there from then on; `llc slam --bag` does the same.
  bool estimate_odometry_time_offset = true;
  int tf_queue_size = 100;           ///< scans waiting for their odometry transform (none waits on a clock); when full the oldest is dropped
  int queue_size = 200;              ///< scans (odometry attached) waiting for the worker thread; when full the oldest is dropped
  /// s of scan time the worker may fall behind the newest scan before it skips the oldest
  /// waiting scans, to catch up (with wheel odometry only: without, every scan is odometry); 0: never.
  double max_lag = 5.0;
  /// Without wheel odometry: scans that come out of their driver's order (header.seq) are put
  /// back in it, at most this many held while one numbered lower is missing (llc::SeqReorder;
  /// a bag sorted by stamps its log wrote after the scans were taken); 0: off.
  int seq_reorder_scans = llc::SeqReorderOptions{}.scans;
  std::string trained_model_path = "llc_classifier.yaml";  ///< default file of ~train_classifier (relative: to the working directory)
  /// The back end's place check (PlaceCheck.srv), asked for every candidate when
  /// place_gate/enabled (as `llc slam` asks its back end); unanswered: the candidate is aligned.
  std::string place_check_service = "esdf_backend/place_check";
  /// The back end's nearby keyframes (NearbyKeyframes.srv), asked when loops/nearby_candidates
  /// and the classifier's candidates gave no loop (as `llc slam` asks its back end); unanswered: none.
  std::string nearby_service = "esdf_backend/nearby_keyframes";
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitLoopClosureParameters(LoopClosureNodeOptions& o, Visit&& visit) {
  visit("model_path", o.model_path);
  visit("odom_frame", o.odom_frame);
  visit("use_wheel_odometry", o.use_wheel_odometry);
  visit("publish_odometry_tf", o.publish_odometry_tf);
  visit("wheel_odometry_wait_scans", o.wheel_odometry_wait_scans);
  visit("odometry_time_offset", o.odometry_time_offset);
  visit("estimate_odometry_time_offset", o.estimate_odometry_time_offset);
  visit("tf_queue_size", o.tf_queue_size);
  visit("queue_size", o.queue_size);
  visit("max_lag", o.max_lag);
  visit("seq_reorder_scans", o.seq_reorder_scans);
  visit("trained_model_path", o.trained_model_path);
  visit("place_check_service", o.place_check_service);
  visit("nearby_service", o.nearby_service);
}

class LoopClosureRos {
 public:
  /// Subscribes scan360, path (the back end's optimised keyframe poses, for training) and
  /// session (keyframes of a session the back end loaded);
  /// publishes keyframes and loop_closures (names relative to nh); serves ~train_classifier.
  /// Throws std::runtime_error on bad parameters or an unreadable model.
  LoopClosureRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// Stops the worker and the service thread before any member goes.
  ~LoopClosureRos();
  LoopClosureRos(const LoopClosureRos&) = delete;
  LoopClosureRos& operator=(const LoopClosureRos&) = delete;

 private:
  /// A scan on its way to the worker, with its wheel-odometry pose when there is one.
  struct PendingScan {
    laser_loop_closure::Scan360::ConstPtr msg;
    std::size_t index = 0;  ///< among the scans received, from 0
    bool has_wheel_odometry = false;
    llc::Pose2 wheel_odometry;
    std::chrono::steady_clock::time_point arrival;  ///< when onScanReceived took it
  };
  /// Every scan as it arrives: numbered, then to the tf filter (wheels) or the backlog.
  void onScanReceived(const laser_loop_closure::Scan360::ConstPtr& msg);
  /// The tf filter's output: the odometry transform at the scan's stamp is in the buffer.
  void onScanWithOdometry(const laser_loop_closure::Scan360::ConstPtr& msg);
  /// The tf filter gave up on a scan (its stamp older than tf's history, no frame, queue full).
  void onOdometryFailure(const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  /// Hands scan `index` (null: it was dropped) on to the backlog once every older scan has been
  /// handed on or dropped: the front end sees the scans in the order they came. Holds receive_mutex_.
  void resolveInOrder(std::size_t index, const PendingScan* scan);
  /// To the backlog; without wheels through seq_order_ first. Under receive_mutex_.
  void enqueue(PendingScan scan);
  /// The scans seq_order_ holds, once no scan came for half a second of wall time (a bag ended
  /// or paused while one was missing). Timer thread.
  void releaseHeldScans();
  void toBacklog(std::vector<PendingScan>& due);  ///< in order; under receive_mutex_
  /// The worker thread: takes scans from the backlog through the front end until stopped.
  void work();
  void processScan(const PendingScan& pending);
  /// The place gate for keyframe `keyframe`'s candidates: the back end's verdict through
  /// place_check_service, or none (align) when it does not answer. Worker thread, under mutex_.
  llc::LoopVerdict placeCheck(std::size_t from, std::size_t to, std::size_t keyframe);
  /// The nearby candidates of keyframe `keyframe`: the back end's through nearby_service, or
  /// none when it does not answer. Worker thread, under mutex_.
  std::vector<llc::NearbyKeyframe> nearbyKeyframes(std::size_t keyframe, std::size_t before, double max_distance, double max_std,
                                           std::size_t count);
  /// Calls a back-end service over `client` (persistent; made again after a failure, at most
  /// every 5 s, at `retry`): "" when it answered, else why not (then `client` is shut down
  /// when the connection is at fault).
  template <class Service>
  [[nodiscard]] std::string callBackEnd(ros::ServiceClient& client, ros::WallTime& retry, const std::string& name, Service& service);
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
  TfListener tf_listener_;  ///< clears the buffer when tf stamps jump back (a looped bag)
  ros::Subscriber scan_sub_, path_sub_, session_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<laser_loop_closure::Scan360>> odometry_filter_;
  ros::ServiceServer train_srv_;
  CallbackThread service_thread_;  ///< ~train_classifier's own queue and thread
  ros::Publisher keyframe_pub_, loop_pub_;
  diagnostic_updater::Updater diagnostics_;
  ros::WallTimer diagnostics_timer_;
  SessionAssembler session_assembler_;  ///< the parts of a restored session (session_sub_'s callback only)
  CallbackTiming callback_timing_;  ///< onScanReceived and onScanWithOdometry (lock wait included)
  CallbackTiming scan_latency_;     ///< a scan's arrival to the end of its processing (queue + front end)  ///< wall time: the health is told while the clock stands still too

  std::unique_ptr<llc::ScanBacklog<PendingScan>> backlog_;
  std::thread worker_;

  // Receiving side (the nodelet's queue and the tf filter): counts and scan numbers.
  std::mutex receive_mutex_;
  std::size_t scans_received_ = 0, filter_passed_ = 0, filter_failed_ = 0, lookup_failed_ = 0;
  /// No odometry transform ever came (wheel_odometry_wait_scans): scans skip the tf filter, and
  /// the worker broadcasts odom -> base itself. Set once, on the receiving thread.
  std::atomic<bool> without_wheels_{false};
  std::map<const laser_loop_closure::Scan360*, PendingScan> awaiting_odometry_;  ///< scans in the tf filter
  std::map<std::size_t, std::optional<PendingScan>> resolved_;  ///< passed (or dropped) ahead of an older scan
  std::size_t next_release_ = 0;  ///< index of the next scan the backlog gets
  llc::SeqReorder<PendingScan> seq_order_;  ///< without wheels: the scans in header.seq order (seq_reorder_scans)
  std::chrono::steady_clock::time_point last_arrival_;  ///< of the newest scan received
  /// Scan stamps back by more than this (s) are a restart: a looped bag or a reset clock (as the merger's rule).
  static constexpr double kClockJumpBack = 1.0;
  ros::Time newest_received_stamp_;
  std::size_t clock_jumps_back_ = 0, scans_given_up_at_jumps_ = 0, given_up_behind_newer_ = 0;
  /// A scan's wheel odometry from tf (read on this side; estimate() on the worker's, under mutex_).
  std::unique_ptr<WheelOdometryReader> wheels_;
  std::string last_filter_problem_;

  std::mutex mutex_;     ///< guards everything below and front_
  std::mutex training_;  ///< one training at a time
  std::size_t malformed_ = 0;
  std::vector<llc::Pose2> optimised_poses_;  ///< from path: keyframe k at index k
  std::array<std::size_t, llc::kLoopRefusalKinds> refusals_{};  ///< candidates not applied, by llc::LoopRefusal
  std::size_t keyframes_restored_ = 0;       ///< keyframes of the last session restored (~load_session of the back end)
  std::size_t models_trained_ = 0, models_swapped_ = 0;
  std::string model_path_;  ///< of the running model
  // Scan-matching odometry (publish_odometry_tf): the front end's own odometry as odom -> base.
  tf2_ros::TransformBroadcaster odometry_broadcaster_;
  ros::Time last_odometry_stamp_;
  std::string last_problem_;
  // The place gate through the back end (worker thread only).
  ros::NodeHandle nh_;
  ros::ServiceClient place_client_, nearby_client_;  ///< see callBackEnd
  ros::WallTime place_client_retry_, nearby_client_retry_;
  std::uint64_t loops_published_ = 0;  ///< LoopClosure messages so far (Keyframe.loops_before)
  std::size_t place_checks_ = 0, place_checks_unanswered_ = 0;
  std::size_t nearby_asked_ = 0, nearby_unanswered_ = 0;
};

}  // namespace llc_ros
