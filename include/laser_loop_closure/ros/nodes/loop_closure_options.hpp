// The loop_closure nodelet's own parameters (its pipeline's are llc::SystemOptions), read by
// name in one place (visitLoopClosureParameters) and shared by its parts: LoopClosureRos,
// ScanReceiver (the input part, shared with the localization nodelet).
#pragma once

#include <string>

#include "laser_loop_closure/ros/nodes/scan_input_options.hpp"

namespace llc_ros {

struct LoopClosureNodeOptions {
  ScanInputOptions input;            ///< how scans and their wheel odometry come in (parameters at this level)
  std::string model_path;            ///< classifier model (YAML); empty: the package's config/classifier.yaml
  /// Without wheel odometry: broadcast odom_frame -> the scan's frame from scan matching, and
  /// give each keyframe its pose in odom_frame, so that the back end publishes map -> odom_frame.
  bool publish_odometry_tf = false;
  std::string trained_model_path = "llc_classifier.yaml";  ///< default file of ~train_classifier (relative: to the working directory)
  /// The back end's place check (PlaceCheck.srv), asked for every candidate when
  /// place_gate/enabled (as `llc slam` asks its back end); unanswered: the candidate is aligned.
  std::string place_check_service = "esdf_backend/place_check";
  /// The back end's nearby keyframes (NearbyKeyframes.srv), asked when loops/nearby_candidates
  /// and the classifier's candidates gave no loop (as `llc slam` asks its back end); unanswered: none.
  std::string nearby_service = "esdf_backend/nearby_keyframes";
  /// Newest keyframes (with their loops) kept to send again when a back end asks on
  /// resend_request (one across a network that lost some); 0: none kept.
  int resend_keyframes = 500;
  /// Keyframes sent packed small (PackedKeyframe on packed_keyframes instead of Keyframe on
  /// keyframes: the scan packed by llc::packScan, no features; multi_robot.launch's robots).
  bool pack_keyframes = false;
  /// A packed keyframe's scan keeps every n-th beam (1: all): the back end's copy, from which it
  /// computes features, aligns other robots' candidates and draws the map; bytes fall about as
  /// 1/n, and so do cross-robot loops (docs/multi_robot.md: 2 lost a robot's join).
  int pack_beam_stride = 1;
  /// m: a packed keyframe's ranges in steps of this (a finer step costs about a bit a beam per halving).
  double pack_range_step = 0.02;
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitLoopClosureParameters(LoopClosureNodeOptions& o, Visit&& visit) {
  visit("model_path", o.model_path);
  visitScanInputParameters(o.input, visit);
  visit("publish_odometry_tf", o.publish_odometry_tf);
  visit("trained_model_path", o.trained_model_path);
  visit("place_check_service", o.place_check_service);
  visit("nearby_service", o.nearby_service);
  visit("resend_keyframes", o.resend_keyframes);
  visit("pack_keyframes", o.pack_keyframes);
  visit("pack_beam_stride", o.pack_beam_stride);
  visit("pack_range_step", o.pack_range_step);
}

}  // namespace llc_ros
