// The loop_closure nodelet's own parameters (its pipeline's are llc::SystemOptions), read by
// name in one place (visitLoopClosureParameters) and shared by its parts: LoopClosureRos,
// ScanReceiver.
#pragma once

#include <string>

#include "laser_loop_closure/core/slam/seq_reorder.hpp"

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

}  // namespace llc_ros
