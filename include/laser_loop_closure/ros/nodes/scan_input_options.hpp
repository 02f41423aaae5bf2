// How a nodelet that runs the front end takes its merged scans in (ScanReceiver and
// WheelOdometryReader): shared by loop_closure (mapping) and localization, read by name in one
// place (visitScanInputParameters) inside each one's own parameter list.
#pragma once

#include <string>

#include "laser_loop_closure/core/slam/seq_reorder.hpp"

namespace llc_ros {

struct ScanInputOptions {
  std::string odom_frame = "odom";   ///< wheel odometry frame (tf odom_frame -> scan's base frame)
  bool use_wheel_odometry = true;    ///< seed scan matching by tf; a scan without it is skipped
  /// With use_wheel_odometry: when this many scans came and not one got its odometry transform
  /// (a bag or robot with no odometry in tf), go on without wheels from then on (those scans
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
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitScanInputParameters(ScanInputOptions& o, Visit&& visit) {
  visit("odom_frame", o.odom_frame);
  visit("use_wheel_odometry", o.use_wheel_odometry);
  visit("wheel_odometry_wait_scans", o.wheel_odometry_wait_scans);
  visit("odometry_time_offset", o.odometry_time_offset);
  visit("estimate_odometry_time_offset", o.estimate_odometry_time_offset);
  visit("tf_queue_size", o.tf_queue_size);
  visit("queue_size", o.queue_size);
  visit("max_lag", o.max_lag);
  visit("seq_reorder_scans", o.seq_reorder_scans);
}

}  // namespace llc_ros
