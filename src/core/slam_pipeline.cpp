#include "laser_loop_closure/core/slam_pipeline.hpp"

#include "laser_loop_closure/core/file_util.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

namespace llc {
namespace {

bool finitePose(const Pose2& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta); }

const SlamOptions& checked(const SlamOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("slam options: " + error);
  return options;
}

}  // namespace

std::string SlamOptions::validate() const {
  std::string error = odometry.validate();
  if (!error.empty()) return "odometry: " + error;
  error = aligner.validate();
  if (!error.empty()) return "aligner: " + error;
  error = loops.validate();
  if (!error.empty()) return "loops: " + error;
  error = esdf.validate();
  if (!error.empty()) return "esdf: " + error;
  return "";
}

SlamPipeline::SlamPipeline(const ClassifierModel& model, const SlamOptions& options)
    : options_(checked(options)), odometry_(options.odometry), detector_(model, options.aligner, options.loops) {}

const std::vector<Pose2>& SlamPipeline::poses() const {
  static const std::vector<Pose2> none;
  return esdf_ ? esdf_->mean() : none;
}

Pose2 SlamPipeline::mapToOdom() const {
  if (keyframes_.empty() || !keyframes_.back().has_wheel_odometry) return Pose2{};
  return compose(esdf_->mean().back(), inverse(keyframes_.back().wheel_odometry));
}

SlamStepResult SlamPipeline::addScan(const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry) {
  SlamStepResult step;
  ++counters_.scans;
  auto skip = [&](std::string reason) {
    ++counters_.skipped_scans;
    step.skip_reason = std::move(reason);
    return step;
  };
  if (!std::isfinite(scan.stamp)) return skip("stamp is not finite");
  if (scan.ranges.size() != scan.bearings.size()) return skip("ranges and bearings differ in count");
  if (wheel_odometry && !finitePose(*wheel_odometry)) return skip("wheel odometry is not finite");
  if (!keyframes_.empty() && scan.stamp < keyframes_.back().stamp) return skip("time went backwards");

  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<const PreparedScan> prepared;
  if (!keyframes_.empty()) {
    const Keyframe& last = keyframes_.back();
    const bool wheels = wheel_odometry && last.has_wheel_odometry;
    if (wheels) {
      const Pose2 guess = between(last.wheel_odometry, *wheel_odometry);
      if (!odometry_.movedEnough(guess)) return step;  // not a keyframe: nothing more to do
      prepared = detector_.aligner().prepare(scan);
      step.odometry = odometry_.match(detector_.prepared(keyframes_.size() - 1), *prepared, guess, true);
    } else {
      // No wheels: every scan is matched to the newest keyframe to know when it moved enough.
      prepared = detector_.aligner().prepare(scan);
      step.odometry = odometry_.match(detector_.prepared(keyframes_.size() - 1), *prepared, tracked_motion_, false);
      tracked_motion_ = step.odometry.motion;
      if (!odometry_.movedEnough(tracked_motion_)) {
        counters_.seconds_odometry += secondsSince(start);
        return step;
      }
    }
    ++(step.odometry.matched ? counters_.matched_steps : counters_.wheel_steps);
  }
  counters_.seconds_odometry += secondsSince(start);

  Keyframe keyframe;
  keyframe.scan_index = scan_index;
  keyframe.stamp = scan.stamp;
  keyframe.scan = scan;
  keyframe.has_wheel_odometry = wheel_odometry != nullptr;
  if (wheel_odometry) keyframe.wheel_odometry = *wheel_odometry;
  const auto backend_start = std::chrono::steady_clock::now();
  if (!esdf_) {
    esdf_ = std::make_unique<Esdf>(wheel_odometry ? *wheel_odometry : Pose2{}, options_.esdf);
  } else {
    esdf_->augment(step.odometry.motion, step.odometry.covariance);
  }
  counters_.seconds_backend += secondsSince(backend_start);
  keyframes_.push_back(std::move(keyframe));
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
  for (const LoopClosure& loop : step.loops.aligned) {
    LoopRecord record;
    record.loop = loop;
    if (!loop.accepted) {
      record.reject_reason = loop.reject_reason;
      ++counters_.refused_by_alignment;
    } else {
      applyLoop(&record);
    }
    step.records.push_back(record);
    loops_.push_back(std::move(record));
  }
  return step;
}

void SlamPipeline::applyLoop(LoopRecord* record) {
  const LoopClosure& loop = record->loop;
  const auto start = std::chrono::steady_clock::now();
  const EsdfUpdateResult update = esdf_->update(loop.from, loop.to, loop.pose, loop.covariance, options_.gate_loops);
  record->innovation_chi2 = update.innovation_chi2;
  record->applied = update.applied;
  if (update.applied) {
    ++counters_.loops_accepted;
  } else {
    record->reject_reason = "backend: " + update.reject_reason;
    ++counters_.refused_by_gate;
  }
  counters_.seconds_backend += secondsSince(start);
}

}  // namespace llc
