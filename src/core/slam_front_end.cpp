#include "laser_loop_closure/core/slam_front_end.hpp"

#include <chrono>
#include <cmath>

#include "laser_loop_closure/core/file_util.hpp"

namespace llc {
namespace {
}  // namespace

SlamFrontEnd::SlamFrontEnd(const ClassifierModel& model, const ScanOdometryOptions& odometry,
                           const ScanAlignerOptions& aligner, const LoopDetectorOptions& loops)
    : odometry_(odometry), detector_(model, aligner, loops) {}

FrontEndStep SlamFrontEnd::addScan(const Scan& scan, const Pose2* wheel_odometry) {
  FrontEndStep step;
  ++counters_.scans;
  auto skip = [&](std::string reason) {
    ++counters_.skipped_scans;
    step.skip_reason = std::move(reason);
    return step;
  };
  if (!std::isfinite(scan.stamp)) return skip("stamp is not finite");
  if (scan.ranges.size() != scan.bearings.size()) return skip("ranges and bearings differ in count");
  if (wheel_odometry && !isFinite(*wheel_odometry)) return skip("wheel odometry is not finite");
  if (has_keyframe_ && scan.stamp < last_keyframe_stamp_) return skip("time went backwards");

  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<const PreparedScan> prepared;
  if (has_keyframe_) {
    const std::size_t last = detector_.size() - 1;
    if (wheel_odometry && last_keyframe_has_wheels_) {
      const Pose2 guess = between(last_keyframe_wheels_, *wheel_odometry);
      if (!odometry_.movedEnough(guess)) return step;  // not a keyframe: nothing more to do
      prepared = detector_.aligner().prepare(scan);
      step.odometry = odometry_.match(detector_.prepared(last), *prepared, guess, true);
    } else {
      // No wheels: every scan is matched to the newest keyframe to know when it moved enough.
      prepared = detector_.aligner().prepare(scan);
      step.odometry = odometry_.match(detector_.prepared(last), *prepared, tracked_motion_, false);
      tracked_motion_ = step.odometry.motion;
      if (!odometry_.movedEnough(tracked_motion_)) {
        counters_.seconds_odometry += secondsSince(start);
        return step;
      }
    }
    ++(step.odometry.matched ? counters_.matched_steps : counters_.wheel_steps);
  }
  counters_.seconds_odometry += secondsSince(start);

  has_keyframe_ = true;
  last_keyframe_stamp_ = scan.stamp;
  last_keyframe_has_wheels_ = wheel_odometry != nullptr;
  if (wheel_odometry) last_keyframe_wheels_ = *wheel_odometry;
  tracked_motion_ = Pose2{};
  step.keyframe = true;
  step.keyframe_index = detector_.add(scan, prepared);
  ++counters_.keyframes;

  step.loops = detector_.detect(step.keyframe_index);
  counters_.pairs_classified += step.loops.compared;
  counters_.candidates += step.loops.candidates;
  counters_.aligned += step.loops.aligned.size();
  counters_.seconds_classify += step.loops.classify_seconds;
  counters_.seconds_align += step.loops.seconds - step.loops.classify_seconds;
  for (const LoopClosure& loop : step.loops.aligned) ++(loop.accepted ? counters_.loops_found : counters_.refused_by_alignment);
  return step;
}

}  // namespace llc
