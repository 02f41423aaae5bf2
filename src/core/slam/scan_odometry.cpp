#include "laser_loop_closure/core/slam/scan_odometry.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/alignment/shape_validation.hpp"
#include "laser_loop_closure/core/slam/seed_selection.hpp"

namespace llc {

std::string ScanOdometryOptions::validate() const {
  if (!(keyframe_distance > 0.0)) return "keyframe_distance must be > 0";
  if (!(keyframe_angle > 0.0)) return "keyframe_angle must be > 0";
  if (!(max_correction_translation > 0.0)) return "max_correction_translation must be > 0";
  if (!(max_correction_rotation > 0.0)) return "max_correction_rotation must be > 0";
  if (!(max_wheel_disagreement >= 0.0)) return "max_wheel_disagreement must be >= 0 (0: off)";
  if (wheel_noise_window < WheelNoiseScale::min_samples)
    return "wheel_noise_window must be >= " + std::to_string(WheelNoiseScale::min_samples);
  if (!(min_overlap_share >= 0.0 && min_overlap_share <= 1.0)) return "min_overlap_share must be in [0, 1]";
  if (!(overlap_distance > 0.0)) return "overlap_distance must be > 0";
  if (!(translation_sigma > 0.0) || !(rotation_sigma > 0.0)) return "translation_sigma and rotation_sigma must be > 0";
  if (!(translation_sigma_per_metre >= 0.0) || !(rotation_sigma_per_metre >= 0.0) || !(rotation_sigma_per_radian >= 0.0))
    return "the per-metre and per-radian sigmas must be >= 0";
  if (!(wheel_sigma_scale >= 1.0)) return "wheel_sigma_scale must be >= 1";
  if (!(icp_covariance_scale >= 0.0) || !std::isfinite(icp_covariance_scale))
    return "icp_covariance_scale must be finite and >= 0";
  if (!(ambiguity_score_drop >= 0.0 && ambiguity_score_drop <= 1.0)) return "ambiguity_score_drop must be in [0, 1] (0: off)";
  // Shifted farther than twice the field's range, no point is left in it: nothing to learn,
  // and a shift of kilometres would score millions of poses for each keyframe.
  if (!(ambiguity_max_shift > 0.0 && ambiguity_max_shift <= 2.0 * correlative.max_range))
    return "ambiguity_max_shift must be > 0 and at most twice correlative/max_range";
  if (local_map_keyframes < 1) return "local_map_keyframes must be >= 1";
  if (!(max_stamp_jitter >= 0.0)) return "max_stamp_jitter must be >= 0";
  if (!(laser_seeded_trim_fraction > 0.0 && laser_seeded_trim_fraction <= 1.0))
    return "laser_seeded_trim_fraction must be in (0, 1]";
  if (!(laser_seeded_polish_translation >= 0.0) || !std::isfinite(laser_seeded_polish_translation) ||
      !(laser_seeded_polish_rotation >= 0.0) || !std::isfinite(laser_seeded_polish_rotation))
    return "laser_seeded_polish_translation and laser_seeded_polish_rotation must be finite and >= 0";
  if (!(max_prediction_gap >= 0.0) || !std::isfinite(max_prediction_gap)) return "max_prediction_gap must be finite and >= 0";
  if (!(max_speed > 0.0) || !(max_turn_rate > 0.0)) return "max_speed and max_turn_rate must be > 0";
  if (!(min_velocity_interval >= 0.0) || !std::isfinite(min_velocity_interval))
    return "min_velocity_interval must be finite and >= 0";
  if (!(restart_after_jump_back > 0.0)) return "restart_after_jump_back must be > 0";
  if (!(seed_min_score_gain >= 0.0 && seed_min_score_gain <= 1.0)) return "seed_min_score_gain must be in [0, 1]";
  if (!(realign_below_overlap >= 0.0 && realign_below_overlap <= 1.0)) return "realign_below_overlap must be in [0, 1]";
  const std::string correlative_error = correlative.validate();
  if (!correlative_error.empty()) return "correlative: " + correlative_error;
  const std::string error = icp.validate();
  return error.empty() ? "" : "icp: " + error;
}

ScanOdometry::ScanOdometry(const ScanOdometryOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("odometry options: " + error);
}

IcpOptions ScanOdometry::withoutRemapping(IcpOptions options) {
  options.remap_ratio = 0.0;
  return options;
}

IcpOptions ScanOdometry::laserSeeded(IcpOptions options) const {
  options = withoutRemapping(options);
  options.trim_fraction = options_.laser_seeded_trim_fraction;
  return options;
}

IcpResult ScanOdometry::polishLaserSeeded(const MatchTarget& previous, const MatchTarget& current, const IcpResult& icp) const {
  if (options_.laser_seeded_polish_translation == 0.0 || !icp.converged) return icp;
  const IcpResult polished =
      alignIcp(current.points, previous.icp_target, icp.pose, withoutRemapping(options_.icp), &current.icp_target.normals, nullptr);
  if (!polished.converged) return icp;
  const Pose2 moved = between(icp.pose, polished.pose);
  const bool near = std::hypot(moved.x, moved.y) <= options_.laser_seeded_polish_translation &&
                    std::abs(moved.theta) <= options_.laser_seeded_polish_rotation;
  return near ? polished : icp;
}

bool ScanOdometry::samePose(const Pose2& a, const Pose2& b) {
  const Pose2 apart = between(a, b);
  return std::hypot(apart.x, apart.y) <= 0.05 && std::abs(apart.theta) <= 0.02;
}

bool ScanOdometry::movedEnough(const Pose2& motion) const {
  return std::hypot(motion.x, motion.y) >= options_.keyframe_distance ||
         std::abs(motion.theta) >= options_.keyframe_angle;
}

Eigen::Matrix3d ScanOdometry::stepCovariance(const Pose2& motion, bool matched) const {
  const double distance = std::hypot(motion.x, motion.y);
  const double scale = matched ? 1.0 : options_.wheel_sigma_scale;
  const double translation = scale * (options_.translation_sigma + options_.translation_sigma_per_metre * distance);
  const double rotation = scale * (options_.rotation_sigma + options_.rotation_sigma_per_metre * distance +
                                    options_.rotation_sigma_per_radian * std::abs(motion.theta));
  return Eigen::Vector3d(translation * translation, translation * translation, rotation * rotation).asDiagonal();
}

Eigen::Matrix3d ScanOdometry::stepCovarianceOf(const IcpResult& icp) {
  // ICP's covariance is of a small motion applied in the keyframe's frame before its pose:
  // x' = dx + x - y dtheta, y' = dy + y + x dtheta (to first order) in the step's parameters.
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Identity();
  jacobian(0, 2) = -icp.pose.y;
  jacobian(1, 2) = icp.pose.x;
  const Eigen::Matrix3d covariance = jacobian * icp.covariance * jacobian.transpose();
  return covariance.allFinite() ? covariance : Eigen::Matrix3d::Zero();
}

bool ScanOdometry::widenAlongAmbiguity(const LikelihoodField& field, const Points2& scan, OdometryStep& step) const {
  if (!(options_.ambiguity_score_drop > 0.0) || !step.matched || !step.icp_covariance.allFinite() ||
      !(step.icp_covariance.topLeftCorner<2, 2>().trace() > 0.0))  // (no ICP covariance: no direction)
    return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(step.icp_covariance.topLeftCorner<2, 2>());
  if (axes.info() != Eigen::Success) return false;
  const Point2 longest = axes.eigenvectors().col(1);  // eigenvalues ascend
  step.ambiguous_shift = ambiguousShift(field, scan, step.motion, longest, options_.ambiguity_max_shift,
                                        options_.correlative.translation_step, options_.ambiguity_score_drop,
                                        options_.correlative.max_points);
  const double held = longest.dot(step.covariance.topLeftCorner<2, 2>() * longest);
  const double wanted = step.ambiguous_shift * step.ambiguous_shift;
  if (!(wanted > held)) return false;
  step.covariance.topLeftCorner<2, 2>() += (wanted - held) * longest * longest.transpose();
  step.widened_along_ambiguity = true;
  return true;
}

void WheelNoiseScale::add(double disagreement) {
  if (!(disagreement >= 0.0) || !std::isfinite(disagreement)) return;
  if (recent_.size() < window_) {
    recent_.push_back(disagreement);
  } else {
    recent_[next_] = disagreement;
    next_ = (next_ + 1) % window_;
  }
}

double WheelNoiseScale::scale() const {
  if (recent_.size() < min_samples) return std::numeric_limits<double>::infinity();
  std::vector<double> sorted = recent_;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  return std::max(1.0, sorted[sorted.size() / 2] / 2.366);
}

OdometryStep ScanOdometry::match(const MatchTarget& previous, const MatchTarget& current, const StepSeeds& seeds) const {
  const Pose2& guess = seeds.guess;
  const bool guess_from_wheels = seeds.from_wheels;
  const double wheel_noise_scale = seeds.wheel_noise_scale;
  const Pose2* tracked = seeds.tracked ? &*seeds.tracked : nullptr;
  const auto start = std::chrono::steady_clock::now();
  OdometryStep step;
  step.motion = guess;
  // Wheels noisier than modelled get the covariance they earn (infinite scale: not known yet).
  const double wheel_scale = std::isfinite(wheel_noise_scale) ? std::max(1.0, wheel_noise_scale) : 1.0;
  auto finish = [&](std::string reason, OdometryRefusal refusal) {
    step.reject_reason = std::move(reason);
    step.refusal = refusal;
    step.covariance = stepCovariance(step.motion, step.matched) * (step.matched ? 1.0 : wheel_scale);
    step.seconds = secondsSince(start);
    return step;
  };
  if (!options_.scan_matching) return finish("", OdometryRefusal::kNone);
  // Remapping keeps the seed along a direction the scans hardly fix: right for the wheels'
  // guess (and the tracked one, carried by them), which know that direction by themselves; not
  // for a guess the laser made (the motion model, a correlative search), which would then
  // never learn a motion along a corridor. Nor would it with the pairs that see that motion
  // trimmed as the farthest: a seed from the laser's motion keeps more of them
  // (laser_seeded_trim_fraction).
  const IcpOptions laser_seeded = laserSeeded(options_.icp);
  const IcpOptions& seeded = guess_from_wheels ? options_.icp : laser_seeded;
  IcpResult icp = alignIcp(current.points, previous.icp_target, guess, seeded, &current.icp_target.normals, nullptr);
  // Those kept pairs include points newly in view with no counterpart, which pull a little:
  // polished with the usual trim, within a bound that keeps the motion the 98% found.
  if (!guess_from_wheels) icp = polishLaserSeeded(previous, current, icp);
  ShapeValidationOptions overlap;
  overlap.max_distance = options_.overlap_distance;
  overlap.min_inlier_share = options_.min_overlap_share;
  // ICP from the wheels' guess, or from the tracked one when ICP from there fits the scans
  // clearly better (wheels that slipped over the last scans); not on a tie (a corridor, where
  // ICP slides: the wheels' guess stands there). How far ICP went is judged from its seed; how
  // much it disagrees with the wheels (a disputed step's covariance holds both) from theirs.
  Pose2 seed = guess;
  const auto same = &ScanOdometry::samePose;
  const SeedScorer scorer(previous.points, options_.correlative);
  auto scored = [&](SeedSource source, const IcpResult& r) {
    return SeedCandidate{source, r.pose, r.converged ? scorer.score(current.points, r.pose) : -1.0};
  };
  if (tracked && guess_from_wheels && isFinite(*tracked) && !same(guess, *tracked)) {
    const IcpResult from_tracked = alignIcp(current.points, previous.icp_target, *tracked, seeded, &current.icp_target.normals);
    // Both reached one pose: the tracked seed is the one that explains it (the wheels slipped).
    const bool agree = icp.converged && from_tracked.converged && same(icp.pose, from_tracked.pose);
    if (agree || selectSeed({scored(SeedSource::kWheels, icp), scored(SeedSource::kTracked, from_tracked)},
                            options_.seed_min_score_gain) == 1) {
      icp = from_tracked;
      seed = *tracked;
      step.tracked = true;
    }
  }
  // The wheels were doubted (ICP failed, went far, overlapped little or disagreed): does the
  // laser clearly place the scan elsewhere? Then its motion is matched, as any other.
  auto recover = [&]() {
    if (!guess_from_wheels || !options_.correlative_recovery) return false;
    const std::optional<Pose2> laser = recoverFromWheels(scorer, previous, current, guess, icp, overlap, wheel_scale);
    if (!laser) return false;
    step.motion = *laser;
    step.matched = true;
    step.recovered = true;
    step.reject_reason.clear();
    step.refusal = OdometryRefusal::kNone;
    // Found where matching was hard (ICP failed or strayed, little overlap): no more certain
    // than a wheel step. A matched step's covariance made the map too sure of such steps for
    // the back end's gate to take the loops that mend them (MIT CSAIL, FR079).
    step.covariance = stepCovariance(step.motion, false);
    step.seconds = secondsSince(start);
    return true;
  };
  if (!icp.converged) {
    if (recover()) return step;
    return finish("icp: " + icp.reject_reason, OdometryRefusal::kIcp);
  }
  const Pose2 correction = between(seed, icp.pose);
  if (guess_from_wheels && (std::hypot(correction.x, correction.y) > options_.max_correction_translation ||
                            std::abs(correction.theta) > options_.max_correction_rotation))
    return recover() ? step : finish("icp moved too far from wheel odometry", OdometryRefusal::kTooFarFromWheels);
  Eigen::Vector3d disagreement = Eigen::Vector3d::Zero();
  bool disputed = false;
  if (guess_from_wheels) {
    // In the step's parameters (x, y, theta), as its covariance is.
    disagreement = Eigen::Vector3d(icp.pose.x - guess.x, icp.pose.y - guess.y, normalizeAngle(icp.pose.theta - guess.theta));
    step.wheel_disagreement = disagreement.dot(stepCovariance(guess, false).ldlt().solve(disagreement));
    disputed = options_.max_wheel_disagreement > 0.0 &&
               step.wheel_disagreement > options_.max_wheel_disagreement * wheel_noise_scale;
  }
  const ShapeValidationResult check = validateShape(current.points, previous.icp_target.tree, icp.pose, overlap, &previous.view);
  step.overlap_share = check.inlier_share;
  if (!check.accepted) {
    if (recover()) return step;
    return finish("overlap " + std::to_string(check.inlier_share) + " below min_overlap_share", OdometryRefusal::kLowOverlap);
  }
  // (A tracked result already overruled the wheels: no search around their guess overrules it.)
  if (disputed && !step.tracked && recover()) return step;
  step.motion = icp.pose;
  step.matched = true;
  finish("", OdometryRefusal::kNone);
  step.icp_covariance = stepCovarianceOf(icp);
  if (disputed) {
    // Which one is wrong is not known: on the drifted logs ICP's minimum, on the raw Intel log
    // the wheels (either as the mean measured the same). ICP's step is kept with a covariance
    // that holds the wheels' within one standard deviation too, so loops can mend either.
    step.disputed = true;
    step.covariance = stepCovariance(guess, false) * wheel_scale + disagreement * disagreement.transpose();
  }
  return step;
}

bool ScanOdometry::withinWheelWindows(const Pose2& pose, const Pose2& guess, double slack_steps) const {
  return withinWindow(options_.correlative, pose, guess, slack_steps) ||
         withinWindow(options_.correlative, pose, Pose2{-guess.x, -guess.y, guess.theta}, slack_steps);
}

std::optional<Pose2> ScanOdometry::recoverFromWheels(const SeedScorer& scorer, const MatchTarget& previous,
                                                     const MatchTarget& current, const Pose2& guess, const IcpResult& icp,
                                                     const ShapeValidationOptions& overlap, double wheel_scale) const {
  // Two windows: around the wheels' guess (a slip, a gap between scans, a turn mismeasured)
  // and around the same step backwards (wheels that count a reverse as forward are wrong in
  // sign, not in size). Not one window wide enough for both: a building's repeated rooms and
  // doors fit metres away too. Ties go to the centre: where the laser cannot tell (a bare
  // corridor), the guess stands.
  const CorrelativeSearchOptions& window = options_.correlative;
  const LikelihoodField& field = scorer.field();
  CorrelativeSearchResult search = searchCorrelative(field, current.points, guess, window);
  const Pose2 backwards{-guess.x, -guess.y, guess.theta};
  if (std::hypot(guess.x, guess.y) > window.max_translation) {
    const CorrelativeSearchResult reverse = searchCorrelative(field, current.points, backwards, window);
    if (reverse.found && (!search.found || reverse.score > search.score)) search = reverse;
  }
  if (!search.found) return std::nullopt;
  const IcpResult refined =
      alignIcp(current.points, previous.icp_target, search.pose, withoutRemapping(options_.icp), &current.icp_target.normals);
  // How well the scans fit anywhere the wheels could be (within two of their standard
  // deviations): a guess a little off always fits worse than ICP's minimum, and says nothing.
  // That is the incumbent the laser's poses must beat.
  const Eigen::Matrix3d wheel_covariance = stepCovariance(guess, false) * wheel_scale;
  CorrelativeSearchOptions wheels = options_.correlative;
  // (Never wider than the search's own window: wheels known to be very noisy would make it a
  // search of the whole neighbourhood, and slow.)
  wheels.max_translation = std::min(window.max_translation, 2.0 * std::sqrt(std::max(wheel_covariance(0, 0), wheel_covariance(1, 1))));
  wheels.translation_step = wheels.cell;
  wheels.max_rotation = std::min(window.max_rotation, 2.0 * std::sqrt(wheel_covariance(2, 2)));
  wheels.rotation_step = std::min(wheels.rotation_step, std::max(1e-3, wheels.max_rotation / 5.0));
  const CorrelativeSearchResult near_wheels = searchCorrelative(field, current.points, guess, wheels);
  const double wheel_score = std::max(near_wheels.found ? near_wheels.score : 0.0, scorer.score(current.points, guess));
  // Only a motion of a window searched: beyond them another place may fit as well, unseen.
  // (One search step of slack: the search's own poses lie on its grid.)
  auto candidate = [&](SeedSource source, const IcpResult& result) {
    const bool in_window = result.converged && withinWheelWindows(result.pose, guess, 1.0);
    return SeedCandidate{source, result.pose, in_window ? scorer.score(current.points, result.pose) : -1.0};
  };
  // The search's own pose last: coarse (the grid's cells favour its own poses a little), it
  // wins only where ICP's trimmed point-to-line pairs slid off what the laser says.
  const std::vector<SeedCandidate> candidates{{SeedSource::kWheels, guess, wheel_score},
                                              candidate(SeedSource::kSearched, refined),
                                              candidate(SeedSource::kWheels, icp),
                                              {SeedSource::kSearchGrid, search.pose, search.score}};
  const std::size_t chosen = selectSeed(candidates, options_.seed_min_score_gain);
  if (chosen == 0) return std::nullopt;
  if (!validateShape(current.points, previous.icp_target.tree, candidates[chosen].pose, overlap, &previous.view).accepted)
    return std::nullopt;
  return candidates[chosen].pose;
}

}  // namespace llc
