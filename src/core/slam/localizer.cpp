#include "laser_loop_closure/core/slam/localizer.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <stdexcept>
#include <utility>

#include "laser_loop_closure/core/common/file_util.hpp"

namespace llc {

std::string LocalizerOptions::validate() const {
  if (global_candidates == 0) return "global_candidates must be >= 1";
  if (!(score_threshold >= 0.0 && score_threshold < 1.0)) return "score_threshold must be in [0, 1) (0: the model's K)";
  if (search_threads == 0 || search_threads > 64) return "search_threads must be in 1 .. 64";
  if (!(min_inlier_share > 0.0 && min_inlier_share <= 1.0)) return "min_inlier_share must be in (0, 1]";
  if (!(global_search_below >= 0.0 && global_search_below <= 1.0)) return "global_search_below must be in [0, 1]";
  const std::string join_error = join.validate();
  if (!join_error.empty()) return "join: " + join_error;
  if (!(fix_min_fitting_share >= 0.0 && fix_min_fitting_share <= 1.0)) return "fix_min_fitting_share must be in [0, 1]";
  if (!(track_radius > 0.0) || !std::isfinite(track_radius)) return "track_radius must be > 0 m";
  if (track_keyframes == 0) return "track_keyframes must be >= 1";
  if (!(min_track_fit > 0.0 && min_track_fit <= 1.0)) return "min_track_fit must be in (0, 1]";
  if (!(max_correction > 0.0) || !std::isfinite(max_correction)) return "max_correction must be > 0 m";
  if (!(max_track_chi2 >= 0.0) || !std::isfinite(max_track_chi2)) return "max_track_chi2 must be >= 0 (0: off)";
  if (confirm_keyframes > 20) return "confirm_keyframes must be at most 20";
  if (lost_after_misfits == 0) return "lost_after_misfits must be >= 1";
  if (!(max_unmatched_travel > 0.0) || !std::isfinite(max_unmatched_travel)) return "max_unmatched_travel must be > 0 m";
  if (!(hint_max_travel > 0.0) || !std::isfinite(hint_max_travel)) return "hint_max_travel must be > 0 m";
  return "";
}

const char* localizationStateName(LocalizationState state) {
  return state == LocalizationState::kLocalized ? "localized" : "lost";
}

namespace {

/// A covariance of (x, y, theta) in a frame turned by `heading`, in the outer frame.
Eigen::Matrix3d rotated(const Eigen::Matrix3d& covariance, double heading) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r.topLeftCorner<2, 2>() << std::cos(heading), -std::sin(heading), std::sin(heading), std::cos(heading);
  return r * covariance * r.transpose();
}

/// The covariance of compose(a, motion) to first order: a's (outer frame) and the motion's (a's frame).
Eigen::Matrix3d composedCovariance(const Pose2& a, const Eigen::Matrix3d& of_a, const Pose2& motion, const Eigen::Matrix3d& of_motion) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d ja = Eigen::Matrix3d::Identity();
  ja(0, 2) = -s * motion.x - c * motion.y;
  ja(1, 2) = c * motion.x - s * motion.y;
  Eigen::Matrix3d jb = Eigen::Matrix3d::Identity();
  jb.topLeftCorner<2, 2>() << c, -s, s, c;
  return ja * of_a * ja.transpose() + jb * of_motion * jb.transpose();
}

/// Validated once, before anything is built from them.
const LocalizerOptions& checkedOptions(const LocalizerOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("localizer options: " + error);
  return options;
}

const SlamSession& checkedMap(const SlamSession& map) {
  const std::string error = map.validate();
  if (!error.empty()) throw std::invalid_argument("map session: " + error);
  if (map.keyframes.empty()) throw std::invalid_argument("map session: no keyframes");
  return map;
}

}  // namespace

ScanAlignerOptions mapAlignerOptions(ScanAlignerOptions aligner, const LocalizerOptions& options) {
  aligner.validation.min_inlier_share = options.min_inlier_share;
  aligner.global_search_below = std::min(aligner.global_search_below, options.global_search_below);
  return aligner;
}

Localizer::Localizer(const ClassifierModel& model, const SlamOptions& slam, const SlamSession& map, const LocalizerOptions& options)
    : options_(checkedOptions(options)),
      front_(model, slam.odometry, slam.aligner, slam.loops),
      map_(model, mapAlignerOptions(slam.aligner, options_), slam.loops),
      map_poses_(checkedMap(map).poses),
      join_(options_.join) {
  // The session's features when they are what this model's extractor makes (checked on the
  // first keyframe, as SlamFrontEnd::restore does), else recomputed.
  const bool stored_features_fit = map.features.size() == map.keyframes.size() && !map.features.empty() &&
                                   map_.describe(map.keyframes.front().scan) == map.features.front();
  // A map larger than the prepared cache keeps its scans and prepares those it aligns (the
  // cache holds the most recently aligned). A smaller one is prepared at load, as before:
  // that is most of its load, on search_threads threads (ScanAligner::prepare is const),
  // keyframe k on thread k % threads.
  const std::size_t cache = slam.loops.prepared_cache;
  const bool lazy = cache > 0 && map.keyframes.size() > cache;
  std::vector<std::shared_ptr<const PreparedScan>> prepared(lazy ? 0 : map.keyframes.size());
  auto prepareEvery = [&](std::size_t first, std::size_t step) {
    for (std::size_t k = first; k < prepared.size(); k += step) prepared[k] = map_.aligner().prepare(map.keyframes[k].scan);
  };
  const std::size_t workers = std::max<std::size_t>(1, std::min(options_.search_threads, prepared.size()));
  std::vector<std::future<void>> others;
  for (std::size_t t = 1; t < workers; ++t) others.push_back(std::async(std::launch::async, prepareEvery, t, workers));
  prepareEvery(0, workers);
  for (std::future<void>& other : others) other.get();
  for (std::size_t k = 0; k < map.keyframes.size(); ++k) {
    std::shared_ptr<const PreparedScan> ready = lazy ? nullptr : std::move(prepared[k]);
    if (!stored_features_fit) {
      map_.add(map.keyframes[k].scan, std::move(ready));  // keeps a copy of the scan when the cache is bounded
      continue;
    }
    map_.addWithFeatures(map.features[k], std::move(ready), cache > 0 ? &map.keyframes[k].scan : nullptr);
  }
}

void Localizer::relocalize(const std::string& why) {
  LocalizationStep ignored;
  loseTrack(why, ignored);
  had_fix_ = true;
}

bool Localizer::hint(const Pose2& pose, double radius) {
  if (!isFinite(pose) || !(radius > 0.0) || !std::isfinite(radius)) return false;
  LocalizationStep ignored;
  loseTrack("a pose hint was given", ignored);
  hint_.active = true;
  hint_.map_from_trajectory = compose(pose, inverse(path_.has_last ? path_.last : Pose2{}));
  hint_.radius = radius;
  hint_.path = path_.length;
  return true;
}

std::vector<std::size_t> Localizer::hintedCandidates(const Pose2& trajectory_pose) const {
  const Pose2 at = compose(hint_.map_from_trajectory, trajectory_pose);
  // The odometry drifts away from the hinted pose as the robot goes on.
  const double radius = hint_.radius + options_.join.drift_per_metre * (path_.length - hint_.path);
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t m = 0; m < map_poses_.size(); ++m) {
    const double d = std::hypot(map_poses_[m].x - at.x, map_poses_[m].y - at.y);
    if (d <= radius) near.emplace_back(d, m);
  }
  const std::size_t count = std::min(near.size(), options_.global_candidates);
  std::partial_sort(near.begin(), near.begin() + std::ptrdiff_t(count), near.end());
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < count; ++i) out.push_back(near[i].second);
  return out;
}

void Localizer::loseTrack(const std::string& why, LocalizationStep& step) {
  if (state_.confirmed) ++counters_.lost_events;
  state_ = TrackState{};
  join_.clear();  // loops of the time before may be the ones that misled it
  recent_.clear();  // and its keyframes, placed by odometry across a kidnapping, would refuse the right fix
  step.lost = true;
  step.why_lost = why;
}

LocalizationStep Localizer::addScan(const Scan& scan, const Pose2* wheel_odometry) {
  const auto start = std::chrono::steady_clock::now();
  LocalizationStep step;
  ++counters_.scans;
  map_.trimPrepared();  // the map takes no keyframes: its cache is trimmed between steps
  const FrontEndStep front = front_.addScan(scan, wheel_odometry);
  counters_.seconds_front_end += secondsSince(start);
  step.skip_reason = front.skip_reason;
  if (front.has_odometry_pose && isFinite(front.odometry_pose)) {
    if (path_.has_last) path_.length += std::hypot(front.odometry_pose.x - path_.last.x, front.odometry_pose.y - path_.last.y);
    path_.last = front.odometry_pose;
    path_.has_last = true;
    if (front.keyframe) {
      step.keyframe = true;
      ++counters_.keyframes;
      recent_.push_back({front.keyframe_index, front.odometry_pose, path_.length});
      while (!recent_.empty() && recent_.front().path < path_.length - options_.join.window) recent_.pop_front();
      // Older keyframes are never aligned again: memory stays bounded over a long run.
      counters_.scans_released += front_.releaseScansBefore(recent_.front().keyframe);
      if (state_.tracking) track(front.keyframe_index, front.odometry_pose, front.odometry.covariance, step);
      else search(front.keyframe_index, front.odometry_pose, step);
    }
    step.has_trajectory_pose = true;
    step.trajectory_pose = front.odometry_pose;
    if (state_.confirmed) {
      step.has_pose = true;
      step.pose = compose(state_.map_from_trajectory, front.odometry_pose);
      const Pose2 motion = between(state_.keyframe_trajectory_pose, front.odometry_pose);
      const bool motion_known = !front.keyframe && front.odometry.covariance.allFinite();
      step.covariance = composedCovariance(compose(state_.map_from_trajectory, state_.keyframe_trajectory_pose),
                                           state_.keyframe_covariance, motion,
                                           motion_known ? front.odometry.covariance : Eigen::Matrix3d::Zero());
    }
  }
  step.state = state();
  step.seconds = secondsSince(start);
  return step;
}

void Localizer::search(std::size_t keyframe, const Pose2& trajectory_pose, LocalizationStep& step) {
  const auto start = std::chrono::steady_clock::now();
  ++counters_.searched_keyframes;
  if (hint_.active && path_.length - hint_.path > options_.hint_max_travel) hint_ = Hint{};  // lapsed: the whole map again
  LoopDetectionResult found;
  if (hint_.active)
    found.aligned = map_.verifyScans(hintedCandidates(trajectory_pose), front_.detector().prepared(keyframe), keyframe,
                                     options_.search_threads);
  else
    found = map_.detectScan(front_.detector().features(keyframe), front_.detector().prepared(keyframe), keyframe,
                            options_.global_candidates, options_.score_threshold, options_.search_threads);
  step.searched = true;
  step.candidates = found.aligned.size();
  const double view_width = front_.detector().prepared(keyframe).view.width();
  std::vector<JoinHypothesis> loops;
  const Pose2 hinted = compose(hint_.map_from_trajectory, trajectory_pose);
  const double hint_radius = hint_.radius + options_.join.drift_per_metre * (path_.length - hint_.path);
  for (const LoopClosure& loop : found.aligned) {
    if (!loop.accepted) continue;
    const Pose2 map_pose = compose(map_poses_[loop.from], loop.pose);
    if (hint_.active && std::hypot(map_pose.x - hinted.x, map_pose.y - hinted.y) > hint_radius) continue;  // not where hinted
    JoinHypothesis hypothesis;
    hypothesis.keyframe = keyframe;
    hypothesis.path = path_.length;
    hypothesis.trajectory_pose = trajectory_pose;
    hypothesis.map_pose = map_pose;
    hypothesis.map_keyframe = loop.from;
    hypothesis.covariance = loop.covariance;
    hypothesis.view_width = view_width;
    loops.push_back(hypothesis);
  }
  step.loops_to_map = loops.size();
  step.search_results = std::move(found.aligned);
  counters_.loops_to_map += loops.size();
  step.join = join_.offer(loops);
  if (step.join.joined) {
    std::string refused = verifyFix(step.join.map_from_trajectory, &step.fit);
    if (refused.empty()) refused = checkFixContext(step.join.newest);
    for (const Pose2& rival : step.join.rival_frames) {  // a place with fewer loops that fits as well: not yet
      double rival_fit = 0.0;
      if (!refused.empty() || !verifyFix(rival, &rival_fit).empty()) continue;
      char why[200];
      std::snprintf(why, sizeof why,
                    "the loops agree, but another place they point to fits the recent keyframes as well (mean fit %.2f "
                    "there, %.2f here)",
                    rival_fit, step.fit);
      refused = why;
    }
    if (!refused.empty()) {
      step.join.joined = false;
      step.join.why_not = refused;
      ++counters_.fixes_refused;
    }
  }
  if (step.join.joined) {
    state_ = TrackState{};
    state_.tracking = true;
    state_.map_from_trajectory = step.join.map_from_trajectory;
    state_.last_fit_path = path_.length;
    state_.keyframe_covariance = rotated(step.join.newest.covariance, map_poses_[step.join.newest.map_keyframe].theta);
    state_.keyframe_trajectory_pose = trajectory_pose;
    join_.clear();
    hint_ = Hint{};
    if (options_.confirm_keyframes == 0) declareFix(step);
  }
  counters_.seconds_search += secondsSince(start);
}

void Localizer::declareFix(LocalizationStep& step) {
  state_.confirmed = true;
  step.fixed = true;
  ++counters_.fixes;
  if (had_fix_) ++counters_.relocalizations;
  had_fix_ = true;
}

double Localizer::fitToMap(std::size_t keyframe, const Pose2& predicted, Pose2* placed, Eigen::Matrix3d* covariance) const {
  // The nearest map keyframes within track_radius (a scan of the poses: cheap next to ICP).
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t m = 0; m < map_poses_.size(); ++m) {
    const double d = std::hypot(map_poses_[m].x - predicted.x, map_poses_[m].y - predicted.y);
    if (d <= options_.track_radius) near.emplace_back(d, m);
  }
  const std::size_t count = std::min(near.size(), options_.track_keyframes);
  std::partial_sort(near.begin(), near.begin() + std::ptrdiff_t(count), near.end());
  const PreparedScan& scan = front_.detector().prepared(keyframe);
  double best_fit = count == 0 ? -1.0 : 0.0;
  *placed = predicted;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t m = near[i].second;
    const IcpResult icp = map_.aligner().refine(map_.prepared(m), scan, between(map_poses_[m], predicted));
    if (!icp.converged) continue;
    const Pose2 moved = compose(map_poses_[m], icp.pose);
    if (std::hypot(moved.x - predicted.x, moved.y - predicted.y) > options_.max_correction) continue;
    const double fit = map_.aligner().fit(map_.prepared(m), scan, icp.pose);
    if (fit <= best_fit) continue;
    best_fit = fit;
    *placed = moved;
    if (covariance) *covariance = rotated(icp.covariance, map_poses_[m].theta);
  }
  return best_fit;
}

std::string Localizer::verifyFix(const Pose2& map_from_trajectory, double* mean_fit) const {
  std::size_t near = 0, fitting = 0;
  double sum = 0.0;
  for (const RecentKeyframe& k : recent_) {
    Pose2 placed;
    const double fit = fitToMap(k.keyframe, compose(map_from_trajectory, k.trajectory_pose), &placed);
    if (fit < 0.0) continue;
    ++near;
    sum += fit;
    fitting += fit >= options_.min_track_fit;
  }
  *mean_fit = near > 0 ? sum / double(near) : -1.0;
  if (near > 0 && double(fitting) >= options_.fix_min_fitting_share * double(near)) return "";
  char why[200];
  std::snprintf(why, sizeof why,
                "the loops agree, but placed there %zu of the %zu recent keyframes near map keyframes fit the map, "
                "mean fit %.2f (fix_min_fitting_share %.2f)",
                fitting, near, *mean_fit, options_.fix_min_fitting_share);
  return why;
}

std::string Localizer::checkFixContext(const JoinHypothesis& loop) const {
  const ContextCheckOptions& options = map_.options().context;
  if (!options.enabled) return "";
  // The map's keyframes around the loop's map keyframe, in its frame (placed by the map).
  const Pose2& anchor = map_poses_[loop.map_keyframe];
  std::vector<ContextScan> old_context, new_context;
  std::vector<Pose2> taken;
  auto spaced = [&](const Pose2& p, std::vector<Pose2>& list) {
    for (const Pose2& q : list)
      if (std::hypot(p.x - q.x, p.y - q.y) < options.spacing) return false;
    list.push_back(p);
    return true;
  };
  old_context.push_back({&map_.prepared(loop.map_keyframe).points, Pose2{}, &map_.prepared(loop.map_keyframe).icp_target.normals});
  taken.push_back(anchor);
  for (std::size_t m = 0; m < map_poses_.size(); ++m) {
    if (m == loop.map_keyframe || std::hypot(map_poses_[m].x - anchor.x, map_poses_[m].y - anchor.y) > options.distance) continue;
    if (!spaced(map_poses_[m], taken)) continue;
    old_context.push_back({&map_.prepared(m).points, between(anchor, map_poses_[m]), &map_.prepared(m).icp_target.normals});
  }
  // The robot's keyframes around its loop's keyframe, in its frame (placed by its odometry).
  std::vector<Pose2> own;
  for (auto it = recent_.rbegin(); it != recent_.rend(); ++it) {
    if (std::abs(it->path - loop.path) > options.distance) continue;
    if (it->keyframe != loop.keyframe && !spaced(it->trajectory_pose, own)) continue;
    const PreparedScan& scan = front_.detector().prepared(it->keyframe);
    const ContextScan c{&scan.points, between(loop.trajectory_pose, it->trajectory_pose), &scan.icp_target.normals};
    if (it->keyframe == loop.keyframe) new_context.insert(new_context.begin(), c);
    else new_context.push_back(c);
  }
  const ContextCheckResult checked = checkLoopContext(old_context, new_context, between(anchor, loop.map_pose), loop.covariance,
                                                      options, map_.aligner().options().icp);
  return checked.accepted ? "" : "the loops agree, but " + checked.reject_reason;
}

double innovationChi2(const Pose2& predicted, const Eigen::Matrix3d& predicted_covariance, const Pose2& measured,
                      const Eigen::Matrix3d& measured_covariance) {
  const Eigen::Matrix3d sum = predicted_covariance + measured_covariance;
  if (!sum.allFinite() || !(std::abs(sum.determinant()) >= 1e-30)) return 0.0;
  const Eigen::Vector3d innovation(measured.x - predicted.x, measured.y - predicted.y, normalizeAngle(measured.theta - predicted.theta));
  return innovation.dot(sum.inverse() * innovation);
}

void fuse(const Pose2& predicted, const Eigen::Matrix3d& predicted_covariance, Pose2* measured,
          Eigen::Matrix3d* measured_covariance) {
  const Eigen::Matrix3d sum = predicted_covariance + *measured_covariance;
  if (!sum.allFinite() || !predicted_covariance.allFinite() || predicted_covariance.trace() <= 0.0 ||
      std::abs(sum.determinant()) < 1e-30)
    return;  // nothing to weigh: the measurement as it is
  const Eigen::Matrix3d gain = predicted_covariance * sum.inverse();
  const Eigen::Vector3d innovation(measured->x - predicted.x, measured->y - predicted.y,
                                   normalizeAngle(measured->theta - predicted.theta));
  const Eigen::Vector3d step = gain * innovation;
  *measured = {predicted.x + step(0), predicted.y + step(1), normalizeAngle(predicted.theta + step(2))};
  const Eigen::Matrix3d fused = (Eigen::Matrix3d::Identity() - gain) * predicted_covariance;
  *measured_covariance = 0.5 * (fused + fused.transpose());
}

void Localizer::carryCovariance(const Pose2& trajectory_pose, const Eigen::Matrix3d& motion_covariance) {
  // Not matched to the map: the newest keyframe's pose is the last matched one's carried by odometry.
  const Pose2 motion = between(state_.keyframe_trajectory_pose, trajectory_pose);
  state_.keyframe_covariance =
      composedCovariance(compose(state_.map_from_trajectory, state_.keyframe_trajectory_pose), state_.keyframe_covariance,
                         motion, motion_covariance.allFinite() ? motion_covariance : Eigen::Matrix3d::Zero());
  state_.keyframe_trajectory_pose = trajectory_pose;
}

void Localizer::track(std::size_t keyframe, const Pose2& trajectory_pose, const Eigen::Matrix3d& motion_covariance,
                      LocalizationStep& step) {
  const auto start = std::chrono::steady_clock::now();
  const Pose2 predicted = compose(state_.map_from_trajectory, trajectory_pose);
  Pose2 best_pose;
  Eigen::Matrix3d best_covariance = Eigen::Matrix3d::Zero();
  const double best_fit = fitToMap(keyframe, predicted, &best_pose, &best_covariance);
  counters_.seconds_track += secondsSince(start);
  step.fit = best_fit;
  if (best_fit < 0.0) {  // off the map: carried by odometry for a while
    ++counters_.off_map_keyframes;
    state_.has_disagreement = false;
    carryCovariance(trajectory_pose, motion_covariance);
    if (path_.length - state_.last_fit_path > options_.max_unmatched_travel) {
      char why[128];
      std::snprintf(why, sizeof why, "no map keyframe fitted over %.1f m of path (max_unmatched_travel)",
                    path_.length - state_.last_fit_path);
      loseTrack(why, step);
    }
    return;
  }
  if (best_fit >= options_.min_track_fit) {
    // The map match and the odometry's prediction weighed by their covariances: along a
    // corridor, where ICP cannot tell how far along it is, the odometry keeps the pose.
    const Pose2 from = compose(state_.map_from_trajectory, state_.keyframe_trajectory_pose);
    const Eigen::Matrix3d predicted_covariance =
        composedCovariance(from, state_.keyframe_covariance, between(state_.keyframe_trajectory_pose, trajectory_pose),
                           motion_covariance.allFinite() ? motion_covariance : Eigen::Matrix3d::Zero());
    Pose2 corrected = best_pose;
    Eigen::Matrix3d covariance = best_covariance;
    // A match the prediction rules out (a poor fit pulled to another optimum) is not taken,
    // the keyframe carried by odometry as off the map, unless the last keyframe's match was
    // ruled out too and agrees with it: then the prediction went astray, and it is taken.
    const double chi2 = innovationChi2(predicted, predicted_covariance, best_pose, best_covariance);
    if (options_.max_track_chi2 > 0.0 && chi2 > options_.max_track_chi2) {
      ++counters_.disagreeing_keyframes;
      const Pose2 implied = compose(best_pose, inverse(trajectory_pose));
      const Pose2 apart = between(state_.disagreeing_map_from_trajectory, implied);
      const bool repeated = state_.has_disagreement && std::hypot(apart.x, apart.y) <= options_.join.max_translation &&
                            std::abs(normalizeAngle(apart.theta)) <= options_.join.max_rotation;
      if (!repeated) {
        state_.has_disagreement = true;
        state_.disagreeing_map_from_trajectory = implied;
        carryCovariance(trajectory_pose, motion_covariance);
        return;
      }
    } else {
      fuse(predicted, predicted_covariance, &corrected, &covariance);
    }
    ++counters_.tracked_keyframes;
    state_.has_disagreement = false;
    state_.map_from_trajectory = compose(corrected, inverse(trajectory_pose));
    state_.keyframe_covariance = covariance;
    state_.keyframe_trajectory_pose = trajectory_pose;
    state_.misfits = 0;
    state_.last_fit_path = path_.length;
    state_.last_fit = best_fit;
    if (!state_.confirmed && ++state_.confirmations >= options_.confirm_keyframes) declareFix(step);
    return;
  }
  ++counters_.misfit_keyframes;
  state_.last_fit = best_fit;
  state_.has_disagreement = false;
  carryCovariance(trajectory_pose, motion_covariance);
  if (!state_.confirmed) {  // on probation: the fix was a look-alike, search on
    ++counters_.fixes_dropped;
    state_ = TrackState{};
    join_.clear();
    return;
  }
  if (++state_.misfits >= options_.lost_after_misfits) {
    char why[160];
    std::snprintf(why, sizeof why, "%zu keyframes in a row did not fit the map (best fit %.2f, min_track_fit %.2f)",
                  state_.misfits, best_fit, options_.min_track_fit);
    loseTrack(why, step);
  }
}

}  // namespace llc
