// The receiving side of the nodelets that run the front end (loop_closure, localization): each merged scan is numbered as it arrives, waits
// in a tf2_ros::MessageFilter for its odometry transform (no thread blocked, no clock waited
// on), takes its wheel odometry (WheelOdometryReader), and goes to the worker's backlog in the
// order the scans came; without wheels, in their driver's header.seq order (llc::SeqReorder).
// It gives up scans whose odometry never comes (a looped bag, a gap behind a newer scan) and
// switches to mapping without wheels when none ever comes (wheel_odometry_wait_scans).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "laser_loop_closure/Scan360.h"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/slam/scan_backlog.hpp"
#include "laser_loop_closure/core/slam/seq_reorder.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/ros/nodes/scan_input_options.hpp"
#include "laser_loop_closure/ros/nodes/wheel_odometry_reader.hpp"

namespace llc_ros {

/// A scan on its way to the worker, with its wheel-odometry pose when there is one.
struct PendingScan {
  laser_loop_closure::Scan360::ConstPtr msg;
  std::size_t index = 0;  ///< among the scans received, from 0
  bool has_wheel_odometry = false;
  llc::Pose2 wheel_odometry;
  std::chrono::steady_clock::time_point arrival;  ///< when the receiver took it
};

/// The wheel odometry of a front-end nodelet's input: read from tf, with the time offset
/// estimated (llc::OdometryTimeOffsetProbe on the pipeline's odometry and aligner) when asked.
std::unique_ptr<WheelOdometryReader> makeWheelOdometryReader(const tf2_ros::Buffer& buffer, const ScanInputOptions& options,
                                                             const llc::SlamOptions& slam);
/// The backlog of a front-end nodelet's input: queue_size scans; with wheels, the oldest skipped
/// beyond max_lag (without, every scan is a step of the odometry chain: none is skipped).
llc::ScanBacklogOptions scanBacklogOptions(const ScanInputOptions& options);

/// A scan off the backlog as the core takes it: converted (false with why for a malformed
/// one), its wheel odometry read again at the offset the estimate chose (logged once, naming
/// `node`, when it chooses).
bool takeScan(const char* node, const PendingScan& pending, WheelOdometryReader& wheels, llc::Scan* scan,
              llc::Pose2* wheel_odometry, std::string* error);

/// A throttled warning, naming `node`, when the backlog dropped scans to catch up (max_lag)
/// since *reported (which it then brings up to date): a user learns of it from the log too.
void warnOfScansDroppedBehind(const char* node, const llc::ScanBacklogCounters& backlog, double max_lag,
                              std::size_t* reported);

/// The backlog's counters in a nodelet's diagnostics (waiting, lag, drops, processed).
void addBacklogTo(const llc::ScanBacklogCounters& backlog, diagnostic_updater::DiagnosticStatusWrapper& status);

class ScanReceiver {
 public:
  /// Subscribes nh's scan360. `buffer`, `wheels` and `backlog` must outlive it. `node` names
  /// the nodelet in its warnings.
  ScanReceiver(std::string node, const ScanInputOptions& options, tf2_ros::Buffer& buffer, ros::NodeHandle nh, WheelOdometryReader& wheels,
               llc::ScanBacklog<PendingScan>& backlog);
  /// Unsubscribes and lets go of the tf filter before the members go.
  ~ScanReceiver();
  ScanReceiver(const ScanReceiver&) = delete;
  ScanReceiver& operator=(const ScanReceiver&) = delete;

  /// The scans seq order holds, once no scan came for half a second of wall time (a bag ended
  /// or paused while one was missing). The nodelet's timer.
  void releaseHeldScans();
  /// No odometry transform ever came: mapping without wheels (set once).
  bool withoutWheels() const { return without_wheels_; }
  std::size_t received() const;
  std::string lastProblem() const;
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& status) const;

 private:
  /// Every scan as it arrives: numbered, then to the tf filter (wheels) or the backlog.
  void onScanReceived(const laser_loop_closure::Scan360::ConstPtr& msg);
  /// The tf filter's output: the odometry transform at the scan's stamp is in the buffer.
  void onScanWithOdometry(const laser_loop_closure::Scan360::ConstPtr& msg);
  /// The tf filter gave up on a scan (its stamp older than tf's history, no frame, queue full).
  void onOdometryFailure(const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  /// Hands scan `index` (null: it was dropped) on to the backlog once every older scan has been
  /// handed on or dropped: the front end sees the scans in the order they came. Under mutex_.
  void resolveInOrder(std::size_t index, const PendingScan* scan);
  /// To the backlog; without wheels through seq_order_ first. Under mutex_.
  void enqueue(PendingScan scan);
  void toBacklog(std::vector<PendingScan>& due);  ///< in order; under mutex_

  const std::string node_;
  const ScanInputOptions options_;
  WheelOdometryReader& wheels_;
  llc::ScanBacklog<PendingScan>& backlog_;
  CallbackTiming callback_timing_;  ///< onScanReceived and onScanWithOdometry (lock wait included)

  mutable std::mutex mutex_;  ///< guards everything below
  std::size_t scans_received_ = 0, filter_passed_ = 0, filter_failed_ = 0, lookup_failed_ = 0;
  /// Set once, on the receiving thread; read by the worker.
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
  std::string last_problem_;

  // Last: made after everything their callbacks use, and gone first.
  std::unique_ptr<tf2_ros::MessageFilter<laser_loop_closure::Scan360>> odometry_filter_;
  ros::Subscriber scan_sub_;
};

}  // namespace llc_ros
