// The localization nodelet's own parameters (the pipeline's, localization/* included, are
// llc::SystemOptions), read by name in one place (visitLocalizationParameters).
#pragma once

#include <string>

#include "laser_loop_closure/ros/nodes/scan_input_options.hpp"

namespace llc_ros {

struct LocalizationNodeOptions {
  ScanInputOptions input;            ///< how scans and their wheel odometry come in (parameters at this level)
  std::string model_path;            ///< classifier model (YAML); empty: the package's config/classifier.yaml
  /// The saved session to localise on (`llc slam --save-session`, ~save_session); required. It
  /// is only read. Relative: to the working directory (~/.ros under roslaunch).
  std::string map_session;
  std::string map_frame = "map";     ///< frame of the session's map, /map and /pose
  bool publish_tf = true;            ///< once fixed, broadcast map_frame -> odom_frame (REP-105); after a loss the last one goes on
  double transform_tolerance = 0.1;  ///< s the broadcast transform is dated into the future
  double tf_publish_period = 0.05;   ///< s between map -> odom broadcasts
  /// m; a pose hint on /initialpose narrows the search to the map keyframes within this of it,
  /// or within 3 standard deviations of its covariance when that is wider.
  double hint_min_radius = 3.0;
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitLocalizationParameters(LocalizationNodeOptions& o, Visit&& visit) {
  visit("model_path", o.model_path);
  visitScanInputParameters(o.input, visit);
  visit("map_session", o.map_session);
  visit("map_frame", o.map_frame);
  visit("publish_tf", o.publish_tf);
  visit("transform_tolerance", o.transform_tolerance);
  visit("tf_publish_period", o.tf_publish_period);
  visit("hint_min_radius", o.hint_min_radius);
}

}  // namespace llc_ros
