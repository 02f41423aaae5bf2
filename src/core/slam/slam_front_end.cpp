#include "laser_loop_closure/core/slam/slam_front_end.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "laser_loop_closure/core/alignment/context_check.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"

namespace llc {

SlamFrontEnd::SlamFrontEnd(const ClassifierModel& model, const ScanOdometryOptions& odometry,
                           const ScanAlignerOptions& aligner, const LoopDetectorOptions& loops)
    : odometry_(odometry), detector_(model, aligner, loops), motion_clock_(odometry.max_stamp_jitter),
      wheel_noise_(odometry.wheel_noise_window) {}

Eigen::Matrix3d SlamFrontEnd::restartCovariance() { return looseLinkCovariance(); }

std::string SlamFrontEnd::restore(const std::vector<Keyframe>& keyframes, const std::vector<std::vector<double>>& features,
                                  bool continue_odometry, bool* features_recomputed, const std::vector<Pose2>* steps) {
  if (keyframes.size() != features.size())
    return std::to_string(keyframes.size()) + " keyframes but " + std::to_string(features.size()) + " feature vectors";
  for (std::size_t k = 1; k < features.size(); ++k)
    if (features[k].size() != features[0].size())
      return "keyframe " + std::to_string(k) + " has " + std::to_string(features[k].size()) + " features, keyframe 0 " +
             std::to_string(features[0].size());
  for (std::size_t k = 0; k < keyframes.size(); ++k)
    if (keyframes[k].scan.ranges.size() != keyframes[k].scan.bearings.size())
      return "keyframe " + std::to_string(k) + ": ranges and bearings differ in count";
  LoopDetector detector(detector_.model(), detector_.aligner().options(), detector_.options());
  bool recompute = false;
  if (!keyframes.empty()) {
    // Stored single-precision values, so compare with float rounding.
    const std::vector<double> fresh = detector.describe(keyframes.front().scan);
    recompute = fresh.size() != features.front().size();
    for (std::size_t i = 0; !recompute && i < fresh.size(); ++i)
      recompute = std::abs(fresh[i] - features.front()[i]) > 1e-5 * (1.0 + std::abs(fresh[i]));
  }
  // With a prepared cache the restored keyframes are prepared when first aligned.
  const bool lazy = detector.options().prepared_cache > 0;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (recompute) {
      detector.add(keyframes[k].scan, lazy ? nullptr : detector.aligner().prepare(keyframes[k].scan));
    } else if (lazy) {
      detector.addWithFeatures(features[k], nullptr, &keyframes[k].scan);
    } else {
      detector.addWithFeatures(features[k], detector.aligner().prepare(keyframes[k].scan));
    }
  }
  if (features_recomputed) *features_recomputed = recompute;
  detector_ = std::move(detector);
  // Every restored keyframe its own chain, unless the run goes on (continue_odometry with the
  // measured steps): then its chains are those the steps made, as the run that saved them had
  // them, so the local map, the context and the calibration go on across the restore.
  const std::size_t n = keyframes.size();
  KeyframeChains chains;
  chains.full_circle = allFullCircle(keyframes);
  chains.pose.assign(n, Pose2{});
  chains.path.assign(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) chains.first.push_back(k);
  chains.start = n;
  if (continue_odometry && n > 0 && steps && steps->size() == n) {
    for (std::size_t k = 1; k < n; ++k) {
      const bool chained = isFinite((*steps)[k]);
      chains.pose[k] = chained ? compose(chains.pose[k - 1], (*steps)[k]) : Pose2{};
      chains.path[k] = chained ? chains.path[k - 1] + std::hypot((*steps)[k].x, (*steps)[k].y) : 0.0;
      chains.first[k] = chained ? chains.first[k - 1] : k;
    }
    chains.start = chains.first.back();
  }
  chains_ = std::move(chains);
  caches_ = KeyframeCaches{};
  counters_ = FrontEndCounters{};
  counters_.keyframes = n;
  motion_.newChain();
  keyframe_ = KeyframeReference{};
  if (continue_odometry && n > 0) {  // the odometry goes on from the newest restored keyframe
    const Keyframe& newest = keyframes.back();
    keyframe_ = KeyframeReference{true, newest.stamp, newest.has_wheel_odometry, newest.wheel_odometry};
    motion_.last_time = newest.stamp;
    motion_clock_.reset(newest.stamp);
  } else if (n > 0) {
    keyframe_.restart_pending = true;
    keyframe_.restart_reason = "a new chain after a restored session";
  }
  wheels_ = ScanWheels{};  // a jump is judged between scans of this run only
  return "";
}

FrontEndStep SlamFrontEnd::addScan(const Scan& scan, const Pose2* wheel_odometry) {
  FrontEndStep step;
  ++counters_.scans;
  auto skip = [&](ScanRefusal why, std::string reason) {
    ++counters_.skipped_scans;
    ++counters_.scans_skipped[std::size_t(why)];
    step.skip = why;
    step.skip_reason = std::move(reason);
    return step;
  };
  if (!std::isfinite(scan.stamp)) return skip(ScanRefusal::kStampNotFinite, "stamp is not finite");
  if (scan.ranges.size() != scan.bearings.size())
    return skip(ScanRefusal::kRangesAndBearingsDiffer, "ranges and bearings differ in count");
  if (wheel_odometry && !isFinite(*wheel_odometry))
    return skip(ScanRefusal::kWheelOdometryNotFinite, "wheel odometry is not finite");
  if (keyframe_.exists && scan.stamp < keyframe_.stamp) {
    // (Stamps that jitter say nothing of the order: the scans are taken as they come.)
    const bool small_jump = keyframe_.stamp - scan.stamp <= odometry_.options().restart_after_jump_back;
    if (small_jump && !motion_clock_.countingScans()) return skip(ScanRefusal::kTimeWentBackwards, "time went backwards");
  }
  if (keyframe_.exists && scan.stamp < keyframe_.stamp - odometry_.options().restart_after_jump_back) {
    // A looped bag or a reset clock: a new chain from this scan on, as after a restored session.
    step.time_jump = "time jumped back " + std::to_string(keyframe_.stamp - scan.stamp) +
                     " s: a new odometry chain, placed by its first loop closure";
    ++counters_.time_jumps;
    keyframe_ = KeyframeReference{};
    keyframe_.restart_pending = true;
    keyframe_.restart_reason = "a new chain after time jumped back";
    motion_.newChain();
    motion_clock_.reset(scan.stamp);
    wheels_ = ScanWheels{};
  }

  const auto start = std::chrono::steady_clock::now();
  motion_.time = motion_clock_.tick(scan.stamp);
  counters_.scans_counted += motion_clock_.countingScans();
  std::shared_ptr<const PreparedScan> prepared;
  // The wheels say the robot hardly moved since the scan before (5 mm, 5 mrad: a stalled
  // reading looked up through tf between two messages moves by a little): the robot stood or
  // crept, or the wheels' source stalled (the laser tells which). A moving reading ends a stall.
  const bool repeated = wheel_odometry && wheels_.has_last && [&] {
    const Pose2 moved = between(wheels_.last, *wheel_odometry);
    return std::hypot(moved.x, moved.y) <= 0.005 && std::abs(moved.theta) <= 0.005;
  }();
  if (!repeated) wheels_.stalled = false;
  if (keyframe_.exists) {
    bool placed = false;
    if (wheel_odometry && keyframe_.has_wheels) {
      const WheelPlacement placement = placeWithWheels(scan, *wheel_odometry, repeated, step, prepared);
      if (placement == WheelPlacement::kNotKeyframe) {
        counters_.seconds_odometry += secondsSince(start);
        setOdometryPose(step);
        return step;
      }
      placed = true;
    }
    if (!placed) {
      // No wheels (or no wheel reference at the newest keyframe: a stall): every scan is
      // matched to the newest keyframe to know when it moved enough, from where the last
      // velocity says it is now.
      if (wheel_odometry) rememberWheels(*wheel_odometry, scan.stamp, repeated);
      if (!prepared) prepared = detector_.aligner().prepare(scan);
      placeByLaser(*prepared, wheel_odometry == nullptr, step);
      if (!odometry_.movedEnough(motion_.track.motion)) {
        counters_.seconds_odometry += secondsSince(start);
        setOdometryPose(step);
        return step;
      }
    }
    ++(step.odometry.matched ? counters_.matched_steps : counters_.wheel_steps);
    counters_.disputed_steps += step.odometry.disputed;
    counters_.recovered_steps += step.odometry.recovered;
    counters_.realigned_steps += step.odometry.realigned;
    counters_.tracked_steps += step.odometry.tracked;
  } else if (keyframe_.restart_pending) {
    step.odometry.covariance = restartCovariance();
    step.odometry.reject_reason = keyframe_.restart_reason;
    step.odometry.refusal = OdometryRefusal::kNewChain;
    chains_.start = detector_.size();  // this keyframe starts the chain the calibration walks
    keyframe_.restart_pending = false;
  }
  counters_.seconds_odometry += secondsSince(start);

  // A stalled reading is no reference: the scans after it go on by the laser to the next keyframe.
  const bool has_wheels = wheel_odometry != nullptr && !wheels_.stalled;
  keyframe_ = KeyframeReference{true, scan.stamp, has_wheels, has_wheels ? *wheel_odometry : Pose2{}};
  wheels_.has_jump = false;  // a new reference: a jump before it is history
  motion_.last_time = motion_.time;
  motion_.track = {};
  step.keyframe = true;
  step.keyframe_index = detector_.add(scan, prepared);
  ++counters_.steps_not_matched[std::size_t(step.odometry.refusal)];
  extendChains(step.keyframe_index, step.odometry.motion, scan.full_circle);
  // The own odometry frame goes on through a new chain (whose motion is the identity).
  const Pose2 motion = isFinite(step.odometry.motion) ? step.odometry.motion : Pose2{};
  own_odometry_.keyframe = own_odometry_.has_keyframe ? compose(own_odometry_.keyframe, motion) : Pose2{};
  own_odometry_.has_keyframe = true;
  step.odometry_pose = own_odometry_.keyframe;
  step.has_odometry_pose = true;
  ++counters_.keyframes;
  return step;
}

SlamFrontEnd::WheelPlacement SlamFrontEnd::placeWithWheels(const Scan& scan, const Pose2& wheels, bool repeated,
                                                          FrontEndStep& step, std::shared_ptr<const PreparedScan>& prepared) {
  const ScanOdometryOptions& o = odometry_.options();
  if (wheels_.has_last) {
    const Pose2 moved = between(wheels_.last, wheels);
    // At least 1 s: logs hold scans whose stamps stand still while the robot moves (the
    // corrected csail log turns 1.15 rad in 0 s). A heading is never judged: any turn
    // fits in a second at max_turn_rate, and a log's stamps say too little to do better.
    const double dt = std::max(scan.stamp - wheels_.last_stamp, 1.0);
    if (std::hypot(moved.x, moved.y) > o.max_speed * dt) {
      const Pose2 since = between(wheels_.before_jump_wheels, wheels);
      if (wheels_.has_jump && std::hypot(since.x, since.y) <= o.max_speed * std::max(scan.stamp - wheels_.before_jump_stamp, 1.0)) {
        // Back where they were going: the jump was a spike, and the old reference holds.
        keyframe_.wheels = wheels_.before_jump_reference;
        wheels_.has_jump = false;
      } else {
        // No robot moves so: measure from a reference that leaves the jump out (as if the
        // robot stood still meanwhile); ICP at the next keyframe finds what it really did.
        wheels_.before_jump_reference = keyframe_.wheels, wheels_.before_jump_wheels = wheels_.last;
        wheels_.before_jump_stamp = wheels_.last_stamp, wheels_.has_jump = true;
        keyframe_.wheels = compose(wheels, inverse(between(keyframe_.wheels, wheels_.last)));
      }
      motion_.track.has_wheels = false;  // its wheel reference holds the jump
      ++counters_.wheel_jumps;
      step.wheel_jump = "wheel odometry jumped " + std::to_string(std::hypot(moved.x, moved.y)) + " m and " +
                        std::to_string(moved.theta) + " rad in " + std::to_string(scan.stamp - wheels_.last_stamp) +
                        " s (beyond max_speed): left out";
    }
  }
  // A repeated reading right after the wheels moved (or in a stall): stood the robot, or
  // stalled the wheels' source? MIT CSAIL's report nothing for 1 s mid-turn, then jump 0.87 rad.
  // (Only where every scan is matched: the laser's last pose is then the scan before's.)
  const bool maybe_stalled =
      repeated && o.stalled_wheels_as_missing && o.match_every_scan && (wheels_.moved || wheels_.stalled);
  rememberWheels(wheels, scan.stamp, repeated);
  // The wheels' guess, and (track_scans) the tracked one: from the last scan ICP placed, on
  // by the wheels' motion since. FR079 turned left while its wheels, slipping for 4 s, said
  // it turned 0.3 rad right: too far off for one ICP from the wheels' guess at the keyframe.
  // A reading that may be stalled says nothing of the motion since: the last velocity does.
  const Pose2 guess = between(keyframe_.wheels, wheels);
  const Pose2 tracked = maybe_stalled ? predictedMotion() : compose(motion_.track.motion, between(motion_.track.wheels, wheels));
  const bool keyframe = odometry_.movedEnough(guess);
  if (!keyframe && !o.match_every_scan) {  // not a keyframe: nothing more to do
    step.odometry.motion = guess;  // where the wheels put this scan from the newest keyframe
    return WheelPlacement::kNotKeyframe;
  }
  prepared = detector_.aligner().prepare(scan);
  // A keyframe's step is matched to the local map; the scans between keep to the newest
  // keyframe (their poses only place them: the map's scans.csv, odom).
  StepSeeds seeds{guess, true, wheel_noise_.scale(), std::nullopt};
  if (motion_.track.has_wheels || maybe_stalled) seeds.tracked = tracked;
  step.odometry = odometry_.match(keyframe ? keyframeStepTarget() : detector_.prepared(detector_.size() - 1), *prepared, seeds);
  // The laser, predicted on, fits clearly better than where the repeated reading says the
  // robot stood, and it moved since the scan before: the wheels stalled. Their reading is no guess and no reference until it
  // changes; the laser's motion is a matched step (not disputed with a stale reading).
  if (maybe_stalled && step.odometry.tracked && !ScanOdometry::samePose(step.odometry.motion, motion_.track.motion)) {
    wheels_.stalled = true;
    ++counters_.stalled_wheel_scans;
    step.odometry.disputed = false;
    step.odometry.covariance = odometry_.stepCovariance(step.odometry.motion, true);
    updateVelocity(step.odometry.motion);
    motion_.track.motion = step.odometry.motion, motion_.last_time = motion_.time;
    motion_.track.has_wheels = false;  // motion_.track.wheels would be the stale reading
    return odometry_.movedEnough(step.odometry.motion) ? WheelPlacement::kKeyframe : WheelPlacement::kNotKeyframe;
  }
  if (!keyframe) {  // matched only to be placed: ICP's pose, or the wheels' when it failed
    if (o.track_scans && step.odometry.disputed) placeDisputedScanByPrediction(*prepared, guess, step);
    // A motion the laser is sure of (not one disputed with the wheels) is tracked on from.
    if (o.track_scans && step.odometry.matched && !step.odometry.disputed) {
      updateVelocity(step.odometry.motion);
      motion_.track.motion = step.odometry.motion, motion_.track.wheels = wheels, motion_.last_time = motion_.time;
      motion_.track.has_wheels = true;
    }
    return WheelPlacement::kNotKeyframe;
  }
  realignDoubtedStep(*prepared, guess, step);
  wheel_noise_.add(step.odometry.wheel_disagreement);
  return WheelPlacement::kKeyframe;
}

void SlamFrontEnd::rememberWheels(const Pose2& wheels, double stamp, bool repeated) {
  wheels_.last = wheels, wheels_.last_stamp = stamp, wheels_.has_last = true;
  wheels_.moved = !repeated;
}

void SlamFrontEnd::placeByLaser(const PreparedScan& scan, bool no_wheels, FrontEndStep& step) {
  const PreparedScan& keyframe = detector_.prepared(detector_.size() - 1);
  const Pose2 predicted = predictedMotion();
  // The prediction is as good as the stamps: unless they were judged steady, or where no
  // velocity predicts (a gap: the last pose stands in), it pulls nothing.
  step.odometry = odometry_.match(keyframe, scan, {predicted, false});
  // A velocity from one bad step predicts far off, and ICP from there fails (the Intel log's
  // turns in place): where the last scan stood may still be near enough.
  if (!step.odometry.matched && !ScanOdometry::samePose(predicted, motion_.track.motion)) {
    OdometryStep from_last = odometry_.match(keyframe, scan, {motion_.track.motion, false});
    if (from_last.matched) {
      ++counters_.laser_fallback_steps;
      step.odometry = std::move(from_last);
    }
  }
  // ICP's covariance, too sure but shaped as the scans are (long along a corridor), lets the
  // loops that mend a laser-only chain's slides pass the gate.
  if (no_wheels) step.odometry.covariance += odometry_.options().icp_covariance_scale * step.odometry.icp_covariance;
  // A keyframe step: how far along the corridor could it be? (The scans between are placed
  // only; their covariance goes nowhere.)
  if (no_wheels && step.odometry.matched && odometry_.options().ambiguity_score_drop > 0.0 &&
      odometry_.movedEnough(step.odometry.motion)) {
    counters_.ambiguous_steps += odometry_.widenAlongAmbiguity(*newestKeyframeField(), scan.points, step.odometry);
  }
  if (step.odometry.matched) updateVelocity(step.odometry.motion);
  motion_.last_time = motion_.time;
  motion_.track.motion = step.odometry.motion;
}

void SlamFrontEnd::placeDisputedScanByPrediction(const PreparedScan& scan, const Pose2& wheel_guess, FrontEndStep& step) {
  // Disputed: the wheels or ICP are wrong. Where the wheels are (FR079 reversing while they
  // count forward), ICP from their guess and from the tracked pose, carried on by the same
  // wheels, can both end in a wrong minimum; the velocity of the scans the laser placed before
  // predicts from elsewhere. Nothing new to try where the prediction is one of those seeds.
  if (!predictsMotion()) return;
  const Pose2 predicted = predictedMotion();
  if (ScanOdometry::samePose(predicted, wheel_guess) || ScanOdometry::samePose(predicted, step.odometry.motion)) return;
  const PreparedScan& newest = detector_.prepared(detector_.size() - 1);
  OdometryStep from_prediction = odometry_.match(newest, scan, {predicted, false});
  if (!from_prediction.matched) return;
  const SeedScorer scorer(newestKeyframeField(), odometry_.options().correlative);
  const SeedSource incumbent = step.odometry.tracked ? SeedSource::kTracked : SeedSource::kWheels;
  if (selectSeed({{incumbent, step.odometry.motion, scorer.score(scan.points, step.odometry.motion)},
                  {SeedSource::kPredicted, from_prediction.motion, scorer.score(scan.points, from_prediction.motion)}},
                 odometry_.options().seed_min_score_gain) != 1)
    return;
  // Still disputed with the wheels: not tracked on from, as the result it replaces.
  from_prediction.disputed = true;
  step.odometry = std::move(from_prediction);
  ++counters_.scans_placed_by_prediction;
}

void SlamFrontEnd::realignDoubtedStep(const PreparedScan& scan, const Pose2& wheel_guess, FrontEndStep& step) {
  const ScanOdometryOptions& o = odometry_.options();
  OdometryStep& odometry = step.odometry;
  if (!odometry.matched || !(odometry.overlap_share < o.realign_below_overlap)) return;
  // The loop aligner's own search, from no guess: ICP from the wheels' (or the tracked) seed
  // can end in a wrong minimum that still overlaps (FR079 turning, scan 4483: 0.36 rad off at
  // 0.65 overlap, where a no-guess alignment fits at 0.84 against 0.23).
  const PreparedScan& newest = detector_.prepared(detector_.size() - 1);
  const ScanAligner& aligner = detector_.aligner();
  const ScanAlignmentResult aligned = aligner.align(newest, scan);
  if (!aligned.accepted) return;
  // Only where the wheels could be, in the windows correlative recovery searches (around their
  // guess, and the same step backwards: FR079's wheels count a reverse as forward): farther, a
  // look-alike room turned 90 degrees fits as well (the drifted Intel log: fit 1.0, 1.56 rad off).
  if (!odometry_.withinWheelWindows(aligned.pose, wheel_guess, 0.0)) return;
  // Scored, as the step's other seeds, in the field of the step's own target (the local map):
  // the newest keyframe alone may see little of what a scan newly in view shows (FR079
  // reversing at scan 1413: the no-guess pose 0.89 against ICP's wrong minimum 0.35 there,
  // 0.28 against 0.33 in the newest keyframe's field).
  const SeedScorer scorer(keyframeStepTarget().points, o.correlative);
  const SeedSource incumbent = odometry.recovered ? SeedSource::kSearched
                               : odometry.tracked ? SeedSource::kTracked : SeedSource::kWheels;
  if (selectSeed({{incumbent, odometry.motion, scorer.score(scan.points, odometry.motion)},
                  {SeedSource::kRealigned, aligned.pose, scorer.score(scan.points, aligned.pose)}},
                 o.seed_min_score_gain) != 1)
    return;
  odometry.motion = aligned.pose;
  // Found where matching was hard: no more certain than a wheel step (as a recovered one).
  odometry.covariance = odometry_.stepCovariance(aligned.pose, false);
  odometry.disputed = false;
  odometry.realigned = true;
}

std::shared_ptr<const LikelihoodField> SlamFrontEnd::newestKeyframeField() {
  const std::size_t newest = detector_.size() - 1;
  if (!caches_.newest_field || caches_.newest_field_of != newest) {
    caches_.newest_field = std::make_shared<const LikelihoodField>(detector_.prepared(newest).points, odometry_.options().correlative);
    caches_.newest_field_of = newest;
  }
  return caches_.newest_field;
}

std::size_t SlamFrontEnd::releaseScansBefore(std::size_t keyframe) {
  const std::size_t kept = std::max<std::size_t>(1, odometry_.options().local_map_keyframes);
  const std::size_t size = detector_.size();
  const std::size_t until = std::min(keyframe, size > kept ? size - kept : 0);
  std::size_t released = 0;
  for (; caches_.released_before < until; ++caches_.released_before, ++released) detector_.releasePrepared(caches_.released_before);
  return released;
}

const MatchTarget& SlamFrontEnd::keyframeStepTarget() {
  const std::size_t newest = detector_.size() - 1;
  const std::size_t wanted = odometry_.options().local_map_keyframes;
  if (wanted > 1 && caches_.local_map_of != newest) {
    caches_.local_map_of = newest;
    caches_.local_map.reset();
    std::vector<ContextScan> scans;  // the newest keyframe's points first (the 5 cm grid keeps the first)
    for (std::size_t k = newest + 1; k-- > 0 && newest - k < wanted && chains_.first[k] == chains_.first[newest];)
      scans.push_back({&detector_.prepared(k).points, between(chains_.pose[newest], chains_.pose[k]), nullptr});
    if (scans.size() >= 2)
      caches_.local_map = std::make_shared<const MatchTarget>(contextCloud(scans, 0.05), detector_.aligner().options().icp,
                                                       detector_.prepared(newest).view);
  }
  return wanted > 1 && caches_.local_map ? *caches_.local_map : detector_.prepared(newest);
}

bool SlamFrontEnd::predictsMotion() const {
  const double dt = motion_.time - motion_.last_time;
  return odometry_.options().predict_motion && dt > 0.0 && dt <= odometry_.options().max_prediction_gap;
}

Pose2 SlamFrontEnd::predictedMotion() const {
  const double dt = motion_.time - motion_.last_time;
  return predictsMotion() ? compose(motion_.track.motion, Pose2{motion_.velocity.x * dt, motion_.velocity.y * dt, motion_.velocity.theta * dt}) : motion_.track.motion;
}

void SlamFrontEnd::updateVelocity(const Pose2& motion) {
  const double dt = motion_.time - motion_.last_time;
  if (!(dt >= odometry_.options().min_velocity_interval && dt <= odometry_.options().max_prediction_gap)) return;
  const Pose2 moved = between(motion_.track.motion, motion);
  const Pose2 velocity{moved.x / dt, moved.y / dt, moved.theta / dt};
  // A velocity no robot has says the stamps are out of step with the scans: not kept.
  if (std::hypot(velocity.x, velocity.y) <= odometry_.options().max_speed &&
      std::abs(velocity.theta) <= odometry_.options().max_turn_rate)
    motion_.velocity = velocity;
}

void SlamFrontEnd::setOdometryPose(FrontEndStep& step) const {
  if (!own_odometry_.has_keyframe || !isFinite(step.odometry.motion)) return;
  step.odometry_pose = compose(own_odometry_.keyframe, step.odometry.motion);
  step.has_odometry_pose = true;
}

std::vector<std::size_t> SlamFrontEnd::surelyElsewhere(std::size_t index) {
  const ThresholdCalibrationOptions& options = detector_.options().calibration;
  std::vector<std::size_t> found;
  if (!options.enabled || index >= chains_.pose.size() || index < chains_.start) return found;
  for (std::size_t j = index; j-- > chains_.start && chains_.path[index] - chains_.path[j] <= options.max_path;)
    if (surelyDifferentPlaces(chains_.pose[j], chains_.pose[index], chains_.path[index] - chains_.path[j], options)) found.push_back(j);
  if (found.size() > options.pairs_per_keyframe) {
    calibration_random_.shuffle(found);
    found.resize(options.pairs_per_keyframe);
  }
  return found;
}

void SlamFrontEnd::extendChains(std::size_t keyframe, const Pose2& motion, bool full_circle) {
  chains_.full_circle = chains_.full_circle && full_circle;
  const bool chained = keyframe > chains_.start && isFinite(motion);
  if (!chained) chains_.start = keyframe;  // the first keyframe of a new chain
  chains_.pose.push_back(chained ? compose(chains_.pose.back(), motion) : Pose2{});
  chains_.path.push_back(chained ? chains_.path.back() + std::hypot(motion.x, motion.y) : 0.0);
  chains_.first.push_back(chains_.start);
}

std::size_t SlamFrontEnd::addKeyframeMadeElsewhere(const Scan& scan, const std::vector<double>& features,
                                                   const Pose2& motion) {
  std::shared_ptr<const PreparedScan> prepared = detector_.aligner().prepare(scan);
  // Features of another length (another feature set on the robot) or not finite are made again here.
  const bool usable = features.size() == detector_.featureCount() &&
                      std::all_of(features.begin(), features.end(), [](double f) { return std::isfinite(f); });
  const Scan* kept = detector_.options().prepared_cache > 0 ? &scan : nullptr;
  const std::size_t index = usable ? detector_.addWithFeatures(features, std::move(prepared), kept)
                                : detector_.add(scan, std::move(prepared));
  extendChains(index, index == 0 ? Pose2{} : motion, scan.full_circle);
  ++counters_.keyframes;
  // The threshold its candidates must reach, calibrated as that front end's was (detectLoops).
  counters_.calibration_pairs += detector_.calibrate(index, surelyElsewhere(index));
  return index;
}

std::vector<ContextKeyframe> SlamFrontEnd::context(std::size_t index, std::size_t before, double distance,
                                                  double spacing) const {
  std::vector<ContextKeyframe> found;
  if (index >= chains_.pose.size()) return found;
  const std::size_t first = chains_.first[index];
  auto take = [&](std::size_t k) { found.push_back({k, between(chains_.pose[index], chains_.pose[k])}); };
  take(index);
  double last = chains_.path[index];
  for (std::size_t k = index; k-- > first && chains_.path[index] - chains_.path[k] <= distance;)
    if (last - chains_.path[k] >= spacing) take(k), last = chains_.path[k];
  last = chains_.path[index];
  for (std::size_t k = index + 1; k < std::min(before, chains_.pose.size()) && chains_.first[k] == first; ++k) {
    if (chains_.path[k] - chains_.path[index] > distance) break;
    if (chains_.path[k] - last >= spacing) take(k), last = chains_.path[k];
  }
  return found;
}

LoopDetectionResult SlamFrontEnd::detectLoops(std::size_t keyframe_index, const CandidateCheck& check,
                                              const NearbyKeyframes& nearby) {
  const auto start = std::chrono::steady_clock::now();
  counters_.calibration_pairs += detector_.calibrate(keyframe_index, surelyElsewhere(keyframe_index));
  counters_.seconds_classify += secondsSince(start);
  LoopDetectionResult loops = detector_.detect(
      keyframe_index, check, nearby,
      [this](std::size_t index, std::size_t before, double distance, double spacing) {
        return context(index, before, distance, spacing);
      });
  counters_.pairs_classified += loops.compared;
  counters_.candidates += loops.candidates;
  counters_.aligned += loops.aligned.size();
  counters_.nearby_aligned += loops.nearby;
  counters_.not_aligned += loops.not_aligned.size();
  counters_.seconds_classify += loops.classify_seconds;
  counters_.seconds_align += loops.seconds - loops.classify_seconds - loops.check_seconds;
  counters_.context_checked += loops.context_checked;
  counters_.context_unchecked += loops.context_unchecked;
  counters_.seconds_context += loops.context_seconds;
  for (const LoopClosure& loop : loops.aligned) {
    if (loop.accepted) ++counters_.loops_found;
    else if (loop.refusal == LoopRefusal::kContext) ++counters_.refused_by_context;
    else ++counters_.refused_by_alignment;
  }
  // The nearby ones are aligned last.
  for (std::size_t i = loops.aligned.size() - loops.nearby; i < loops.aligned.size(); ++i)
    counters_.nearby_found += loops.aligned[i].accepted;
  return loops;
}

SelfTrainingSet SlamFrontEnd::selfTrainingSet(const std::vector<Pose2>& optimised_poses) const {
  const std::size_t placed = std::min(optimised_poses.size(), detector_.size());
  std::vector<std::vector<double>> features;
  features.reserve(placed);
  for (std::size_t k = 0; k < placed; ++k) features.push_back(detector_.features(k));
  const std::vector<Pose2> poses(optimised_poses.begin(), optimised_poses.begin() + long(placed));
  return llc::selfTrainingSet(features, poses, detector_.model().features.feature_set, chains_.full_circle,
                              detector_.options().min_keyframe_gap);
}

}  // namespace llc
