// The loop_closure nodelet's object: merged scans in; the shared front end (llc::SlamFrontEnd:
// keyframes, ICP odometry seeded by wheel odometry from tf, the classifier against every older
// keyframe with no pose prior, CRF-match/ICP/shape validation) out as Keyframe and
// LoopClosure messages for a back end.
//
// Threads: no callback waits on the ROS clock (which stops when a bag ends or is paused).
// ScanReceiver numbers the scans, gives them their wheel odometry and queues them in a bounded
// backlog (llc::ScanBacklog). One worker thread owns the front end and empties the backlog
// through it, asking the back end (BackEndClient) while it chooses candidates. Nothing else
// touches the front end: a restored session and a trained model are posted to the worker as
// tasks it runs between two scans, and diagnostics read what the worker last published. So no
// lock is held while the worker waits on the back end, and ~train_classifier (its own callback
// queue and thread) answers while scans are processed and while the clock stands still.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <std_msgs/UInt32.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/TrainClassifier.h"
#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
#include "laser_loop_closure/core/slam/scan_backlog.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/ros/io/callback_thread.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/ros/io/session_parts.hpp"
#include "laser_loop_closure/ros/io/tf_listener.hpp"
#include "laser_loop_closure/ros/nodes/resend_buffer.hpp"
#include "laser_loop_closure/ros/nodes/back_end_client.hpp"
#include "laser_loop_closure/ros/nodes/loop_closure_options.hpp"
#include "laser_loop_closure/ros/nodes/scan_receiver.hpp"
#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"

namespace llc_ros {

class LoopClosureRos {
 public:
  /// Subscribes scan360, path (the back end's optimised keyframe poses, for training) and
  /// session (keyframes of a session the back end loaded);
  /// publishes keyframes and loop_closures (names relative to nh); serves ~train_classifier.
  /// Throws std::runtime_error on bad parameters or an unreadable model.
  LoopClosureRos(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// Stops the service thread, the receiver and the worker before any member goes.
  ~LoopClosureRos();
  LoopClosureRos(const LoopClosureRos&) = delete;
  LoopClosureRos& operator=(const LoopClosureRos&) = delete;

 private:
  /// What the worker tells the other threads, published after every scan and task.
  struct WorkerState {
    llc::FrontEndCounters counters;
    double threshold = 0.0;  ///< the classifier's K
    std::size_t malformed = 0;
    std::array<std::size_t, llc::kLoopRefusalKinds> refusals{};  ///< candidates not applied, by llc::LoopRefusal
    std::size_t keyframes_restored = 0;  ///< of the last session restored (~load_session of the back end)
    /// Memory of the keyframes: scans kept to prepare again, features, scans kept prepared.
    std::size_t scan_bytes = 0, feature_bytes = 0, prepared_held = 0;
    std::size_t models_swapped = 0;
    std::string model_path;  ///< of the running model
    std::string last_problem;
    std::optional<llc::OdometryTimeOffsetProbeResult> estimate;
  };

  /// The worker thread: scans from the backlog through the front end (and the tasks posted).
  void work();
  void processScan(const PendingScan& pending);
  /// The worker's state to the other threads (worker thread).
  void publishState();
  /// Runs `task` on the worker between two scans and waits for it (any other thread).
  template <class Result>
  Result onWorker(std::function<Result()> task);
  /// publish_odometry_tf: broadcasts odom_frame -> the scan's frame for this scan and, for a
  /// keyframe, gives it its pose in odom_frame (as has_wheel_odometry / wheel_odometry).
  void publishOdometry(const llc::FrontEndStep& step, const std_msgs::Header& scan_header, llc::Keyframe* keyframe);
  void onPath(const nav_msgs::Path::ConstPtr& msg);
  void onResendRequest(const std_msgs::UInt32::ConstPtr& msg);
  /// A session the back end restored: the keyframes (and their features) replace ours, on the worker.
  void onSession(const laser_loop_closure::Session::ConstPtr& msg);
  /// Trains on the service thread (scans keep flowing); the worker gives the training set and swaps the model in.
  bool trainClassifier(laser_loop_closure::TrainClassifier::Request& request,
                       laser_loop_closure::TrainClassifier::Response& response);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  LoopClosureNodeOptions options_;
  llc::SystemOptions system_;
  tf2_ros::Buffer tf_buffer_;
  TfListener tf_listener_;  ///< clears the buffer when tf stamps jump back (a looped bag)
  // Each CallbackThread is declared before the handles registered on its queue: members go in
  // reverse order, and a handle that goes after its queue locks a destroyed mutex (unloading the
  // nodelet then aborted the whole manager: localize_kidnap.test loads and unloads each nodelet).
  CallbackThread service_thread_;  ///< ~train_classifier's own queue and thread
  ros::Subscriber path_sub_, session_sub_;
  ros::ServiceServer train_srv_;
  ros::Publisher keyframe_pub_, packed_keyframe_pub_, loop_pub_;
  ros::Subscriber resend_sub_;  ///< resend_request: a back end lacks keyframes from this number on
  std::unique_ptr<ResendBuffer> sent_;
  std::atomic<std::size_t> keyframes_sent_again_{0};
  diagnostic_updater::Updater diagnostics_;
  ros::WallTimer diagnostics_timer_;
  SessionAssembler session_assembler_;  ///< the parts of a restored session (session_sub_'s callback only)
  CallbackTiming scan_latency_;  ///< a scan's arrival to the end of its processing (queue + front end)

  // The worker's own: nothing else touches them.
  std::unique_ptr<llc::SlamFrontEnd> front_;
  WorkerState state_;
  std::unique_ptr<BackEndClient> back_end_;
  tf2_ros::TransformBroadcaster odometry_broadcaster_;  ///< scan-matching odometry (publish_odometry_tf)
  ros::Time last_odometry_stamp_;
  std::uint64_t loops_published_ = 0;  ///< LoopClosure messages so far (Keyframe.loops_before)

  mutable std::mutex state_mutex_;  ///< guards published_
  WorkerState published_;
  std::mutex poses_mutex_;                   ///< guards optimised_poses_
  std::vector<llc::Pose2> optimised_poses_;  ///< from path: keyframe k at index k
  std::mutex training_;                      ///< one training at a time
  std::atomic<std::size_t> models_trained_{0};

  /// Wheel odometry from tf: read by the receiver, estimate() by the worker.
  std::unique_ptr<WheelOdometryReader> wheels_;
  std::unique_ptr<llc::ScanBacklog<PendingScan>> backlog_;
  std::unique_ptr<ScanReceiver> receiver_;
  std::thread worker_;
};

}  // namespace llc_ros
