// Every parameter of the SLAM pipeline under one name, listed once: the nodelets read them
// from the ROS parameter server and `llc slam --config` from a YAML file through this list,
// so a name means the same everywhere. Names are the options' field names, nested by stage
// ("odometry/keyframe_distance", "aligner/icp/max_iterations"), as rosparam nests YAML maps.
// A field not listed here is fixed at its default for users (tests may still set it): of the
// odometry: wheel_noise_window, ambiguity_max_shift, the laser-seeded ICP's trim and
// polish bounds, max_prediction_gap, min_velocity_interval, restart_after_jump_back, and its
// ICP's and correlative search's iterations, tolerances, grids and sampling.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/multi_robot_slam.hpp"
#include "laser_loop_closure/core/slam/session_pruning.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"

namespace llc {

/// The options of everything `llc slam` and the nodelets run.
struct SystemOptions {
  SlamOptions slam{};
  OccupancyGridOptions map{};
  LocalizerOptions localization{};  ///< llc localize and mode localization only
  MultiRobotOptions multi_robot{};  ///< llc slam with several inputs only
  SessionPruningOptions lifelong{};  ///< llc slam --lifelong only: the session saved at bounded size
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitJoinParameters(const std::string& prefix, TrajectoryJoinOptions& o, Visit&& visit) {
  visit(prefix + "min_keyframes", o.min_keyframes);
  visit(prefix + "min_spread", o.min_spread);
  visit(prefix + "min_new_view", o.min_new_view);
  visit(prefix + "max_translation", o.max_translation);
  visit(prefix + "max_rotation", o.max_rotation);
  visit(prefix + "drift_per_metre", o.drift_per_metre);
  visit(prefix + "drift_rad_per_metre", o.drift_rad_per_metre);
  visit(prefix + "window", o.window);
  visit(prefix + "min_lead", o.min_lead);
}

template <class Visit>
void visitIcpParameters(const std::string& prefix, IcpOptions& o, Visit&& visit) {
  visit(prefix + "max_iterations", o.max_iterations);
  visit(prefix + "max_correspondence_distance", o.max_correspondence_distance);
  visit(prefix + "trim_fraction", o.trim_fraction);
  visit(prefix + "huber_delta", o.huber_delta);
  visit(prefix + "translation_tolerance", o.translation_tolerance);
  visit(prefix + "rotation_tolerance", o.rotation_tolerance);
  visit(prefix + "min_correspondences", o.min_correspondences);
  visit(prefix + "degeneracy_ratio", o.degeneracy_ratio);
  visit(prefix + "remap_ratio", o.remap_ratio);
  visit(prefix + "max_source_points", o.max_source_points);
  visit(prefix + "max_normal_angle", o.max_normal_angle);
  visit(prefix + "fixed_pairs_after", o.fixed_pairs_after);
}

/// Calls visit(name, field) for every parameter; field is a double, int, bool or std::size_t.
template <class Visit>
void visitParameters(SystemOptions& options, Visit&& visit) {
  ScanOdometryOptions& odometry = options.slam.odometry;
  visit("odometry/keyframe_distance", odometry.keyframe_distance);
  visit("odometry/keyframe_angle", odometry.keyframe_angle);
  visit("odometry/scan_matching", odometry.scan_matching);
  visit("odometry/max_correction_translation", odometry.max_correction_translation);
  visit("odometry/max_correction_rotation", odometry.max_correction_rotation);
  visit("odometry/max_wheel_disagreement", odometry.max_wheel_disagreement);
  visit("odometry/min_overlap_share", odometry.min_overlap_share);
  visit("odometry/overlap_distance", odometry.overlap_distance);
  visit("odometry/translation_sigma", odometry.translation_sigma);
  visit("odometry/translation_sigma_per_metre", odometry.translation_sigma_per_metre);
  visit("odometry/rotation_sigma", odometry.rotation_sigma);
  visit("odometry/rotation_sigma_per_metre", odometry.rotation_sigma_per_metre);
  visit("odometry/rotation_sigma_per_radian", odometry.rotation_sigma_per_radian);
  visit("odometry/wheel_sigma_scale", odometry.wheel_sigma_scale);
  visit("odometry/predict_motion", odometry.predict_motion);
  visit("odometry/match_every_scan", odometry.match_every_scan);
  visit("odometry/seed_min_score_gain", odometry.seed_min_score_gain);
  visit("odometry/track_scans", odometry.track_scans);
  visit("odometry/stalled_wheels_as_missing", odometry.stalled_wheels_as_missing);
  visit("odometry/icp_covariance_scale", odometry.icp_covariance_scale);
  visit("odometry/ambiguity_score_drop", odometry.ambiguity_score_drop);
  visit("odometry/local_map_keyframes", odometry.local_map_keyframes);
  visit("odometry/max_stamp_jitter", odometry.max_stamp_jitter);
  visit("odometry/max_speed", odometry.max_speed);
  visit("odometry/max_turn_rate", odometry.max_turn_rate);
  // Of the odometry's ICP and correlative search, what shapes a step; the rest (iterations,
  // tolerances, sampling) stays at the options' defaults, which tests may still set.
  visit("odometry/icp/max_correspondence_distance", odometry.icp.max_correspondence_distance);
  visit("odometry/icp/trim_fraction", odometry.icp.trim_fraction);
  visit("odometry/icp/remap_ratio", odometry.icp.remap_ratio);
  visit("odometry/correlative_recovery", odometry.correlative_recovery);
  visit("odometry/correlative/max_translation", odometry.correlative.max_translation);
  visit("odometry/correlative/max_rotation", odometry.correlative.max_rotation);
  visit("odometry/realign_below_overlap", odometry.realign_below_overlap);

  LoopDetectorOptions& loops = options.slam.loops;
  visit("loops/min_keyframe_gap", loops.min_keyframe_gap);
  visit("loops/max_candidates", loops.max_candidates);
  visit("loops/checked_candidates", loops.checked_candidates);
  visit("loops/score_threshold", loops.score_threshold);
  visit("loops/stop_at_first_accepted", loops.stop_at_first_accepted);
  visit("loops/nearby_candidates", loops.nearby_candidates);
  visit("loops/nearby_distance", loops.nearby_distance);
  visit("loops/nearby_max_std", loops.nearby_max_std);
  visit("loops/nearby_min_predicted_fit", loops.nearby_min_predicted_fit);
  visit("loops/threads", loops.threads);
  visit("loops/prepared_cache", loops.prepared_cache);
  visit("loops/translation_sigma", loops.translation_sigma);
  visit("loops/rotation_sigma", loops.rotation_sigma);
  visit("loops/calibration/enabled", loops.calibration.enabled);
  visit("loops/calibration/target_false_alarm", loops.calibration.target_false_alarm);
  visit("loops/calibration/raise_only", loops.calibration.raise_only);
  visit("loops/calibration/min_distance", loops.calibration.min_distance);
  visit("loops/calibration/drift_per_metre", loops.calibration.drift_per_metre);
  visit("loops/calibration/max_path", loops.calibration.max_path);
  visit("loops/calibration/min_pairs", loops.calibration.min_pairs);
  visit("loops/calibration/max_pairs", loops.calibration.max_pairs);
  visit("loops/calibration/pairs_per_keyframe", loops.calibration.pairs_per_keyframe);
  visit("loops/context/enabled", loops.context.enabled);
  visit("loops/context/distance", loops.context.distance);
  visit("loops/context/spacing", loops.context.spacing);
  visit("loops/context/min_scans", loops.context.min_scans);
  visit("loops/context/search_shift", loops.context.search_shift);
  visit("loops/context/search_restarts", loops.context.search_restarts);
  visit("loops/context/fit_distance", loops.context.fit_distance);
  visit("loops/context/max_alternative_gain", loops.context.max_alternative_gain);
  visit("loops/context/alternative_distance", loops.context.alternative_distance);
  visit("loops/context/max_points", loops.context.max_points);
  visit("loops/context/cell", loops.context.cell);
  visit("loops/context/parallel", loops.context.parallel);

  ScanAlignerOptions& aligner = options.slam.aligner;
  visit("aligner/max_range", aligner.max_range);
  visit("aligner/selection_distance", aligner.selection_distance);
  visit("aligner/reverse_below", aligner.reverse_below);
  visit("aligner/parallel", aligner.parallel);
  visit("aligner/global_search_below", aligner.global_search_below);
  visit("aligner/min_relative_overlap", aligner.min_relative_overlap);
  visit("aligner/weak_direction_shift", aligner.weak_direction_shift);
  visit("aligner/weak_direction_restarts", aligner.weak_direction_restarts);
  visit("aligner/weak_direction_above", aligner.weak_direction_above);
  visit("aligner/global/sample_spacing", aligner.global.sample_spacing);
  visit("aligner/global/angle_bin", aligner.global.angle_bin);
  visit("aligner/global/rotations", aligner.global.rotations);
  visit("aligner/global/cell", aligner.global.cell);
  visit("aligner/global/max_translation", aligner.global.max_translation);
  visit("aligner/global/max_normal_angle", aligner.global.max_normal_angle);
  visit("aligner/global/hypotheses", aligner.global.hypotheses);
  visit("aligner/global/distinct_distance", aligner.global.distinct_distance);
  visit("aligner/crf/node_spacing", aligner.crf.node_spacing);
  visit("aligner/crf/max_nodes", aligner.crf.max_nodes);
  visit("aligner/crf/break_distance", aligner.crf.break_distance);
  visit("aligner/crf/candidates", aligner.crf.candidates);
  visit("aligner/crf/temperature", aligner.crf.temperature);
  visit("aligner/crf/min_confidence", aligner.crf.min_confidence);
  visitIcpParameters("aligner/icp/", aligner.icp, visit);
  visit("aligner/validation/max_distance", aligner.validation.max_distance);
  visit("aligner/validation/min_inlier_share", aligner.validation.min_inlier_share);
  visit("aligner/validation/only_in_view", aligner.validation.only_in_view);
  visit("aligner/validation/max_seen_through_share", aligner.validation.max_seen_through_share);
  visit("aligner/validation/free_space_margin", aligner.validation.free_space_margin);
  visit("aligner/validation/max_position_std", aligner.validation.max_position_std);

  EsdfOptions& esdf = options.slam.esdf;
  visit("esdf/relinearize_translation", esdf.relinearize_translation);
  visit("esdf/relinearize_rotation", esdf.relinearize_rotation);
  visit("esdf/relinearize_chi2", esdf.relinearize_chi2);
  visit("esdf/max_edges_relinearized_in_place", esdf.max_edges_relinearized_in_place);
  visit("esdf/max_relinearizations", esdf.max_relinearizations);
  visit("esdf/reorder_fill_ratio", esdf.reorder_fill_ratio);
  visit("esdf/loop_chi2_threshold", esdf.loop_chi2_threshold);
  visit("esdf/prior_information", esdf.prior_information);
  visit("esdf/max_information", esdf.max_information);
  visit("esdf/robust_loop_chi2", esdf.robust_loop_chi2);
  visit("esdf/gate_loops", options.slam.gate_loops);

  LoopConsensusOptions& consensus = options.slam.consensus;
  visit("consensus/min_loops", consensus.min_loops);
  visit("consensus/max_chi2", consensus.max_chi2);
  visit("consensus/max_keyframes_apart", consensus.max_keyframes_apart);
  visit("consensus/max_translation", consensus.max_translation);
  visit("consensus/max_rotation", consensus.max_rotation);
  visit("consensus/max_kept", consensus.max_kept);


  PlaceGateOptions& place_gate = options.slam.place_gate;
  visit("place_gate/enabled", place_gate.enabled);
  visit("place_gate/radius", place_gate.radius);
  visit("place_gate/chi2_threshold", place_gate.chi2_threshold);

  LocalizerOptions& localization = options.localization;
  visit("localization/global_candidates", localization.global_candidates);
  visit("localization/score_threshold", localization.score_threshold);
  visit("localization/search_threads", localization.search_threads);
  visit("localization/min_inlier_share", localization.min_inlier_share);
  visit("localization/global_search_below", localization.global_search_below);
  visitJoinParameters("localization/join/", localization.join, visit);
  visit("localization/fix_min_fitting_share", localization.fix_min_fitting_share);
  visit("localization/confirm_keyframes", localization.confirm_keyframes);
  visit("localization/track_radius", localization.track_radius);
  visit("localization/track_keyframes", localization.track_keyframes);
  visit("localization/min_track_fit", localization.min_track_fit);
  visit("localization/max_correction", localization.max_correction);
  visit("localization/max_track_chi2", localization.max_track_chi2);
  visit("localization/lost_after_misfits", localization.lost_after_misfits);
  visit("localization/max_unmatched_travel", localization.max_unmatched_travel);
  visit("localization/hint_max_travel", localization.hint_max_travel);

  MultiRobotOptions& multi_robot = options.multi_robot;
  visit("multi_robot/cross_candidates", multi_robot.cross_candidates);
  visit("multi_robot/search_threads", multi_robot.search_threads);
  visitJoinParameters("multi_robot/join/", multi_robot.join, visit);
  SessionPruningOptions& lifelong = options.lifelong;
  visit("lifelong/place_size", lifelong.place_size);
  visit("lifelong/heading_sectors", lifelong.heading_sectors);
  visit("lifelong/keep_per_place", lifelong.keep_per_place);
  visit("lifelong/keep_newest", lifelong.keep_newest);

  OccupancyGridOptions& map = options.map;
  visit("map/resolution", map.resolution);
  visit("map/max_range", map.max_range);
  visit("map/no_return_free_range", map.no_return_free_range);
  visit("map/hit_log_odds", map.hit_log_odds);
  visit("map/miss_log_odds", map.miss_log_odds);
  visit("map/clamp_log_odds", map.clamp_log_odds);
  visit("map/occupied_threshold", map.occupied_threshold);
  visit("map/free_threshold", map.free_threshold);
  visit("map/margin", map.margin);
  visit("map/redraw_distance", map.redraw_distance);
  visit("map/redraw_angle", map.redraw_angle);
  visit("map/max_draws_per_update", map.max_draws_per_update);
  visit("map/grow_step", map.grow_step);
}

/// Every parameter name, in the order above.
std::vector<std::string> systemParameterNames();
/// For a parameter an earlier version had and this one folded into another: what to set
/// instead (e.g. "folded into odometry/seed_min_score_gain in 0.23.0"); empty for any other name.
std::string retiredParameterNote(const std::string& name);

/// Reads a YAML file of nested maps (odometry: {keyframe_distance: 1.0}, ...) onto `options`:
/// names it does not give keep their value. Throws std::runtime_error naming the file and the
/// key for an unknown key, a value of the wrong type, or options that do not validate.
void loadSystemOptionsYaml(const std::string& path, SystemOptions* options);
/// Sets parameters given as text, e.g. {"odometry/keyframe_distance", "0.5"} from the command
/// line's --odometry/keyframe_distance 0.5, with the same conversion and checks as a YAML file;
/// throws std::runtime_error naming `source` on an unknown name, a bad value or invalid options.
void setSystemParameters(const std::vector<std::pair<std::string, std::string>>& values, const std::string& source,
                         SystemOptions* options);
/// Every parameter's name and its built-in default as YAML text, in visiting order.
std::vector<std::pair<std::string, std::string>> systemParameterDefaults();

}  // namespace llc
