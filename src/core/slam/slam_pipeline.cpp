#include "laser_loop_closure/core/slam/slam_pipeline.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace llc {
namespace {

const SlamOptions& checked(const SlamOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("slam options: " + error);
  return options;
}

}  // namespace

std::string PlaceGateOptions::validate() const {
  if (!(radius > 0.0) || !std::isfinite(radius)) return "radius must be > 0 m";
  if (!(chi2_threshold > 0.0)) return "chi2_threshold must be > 0";
  return "";
}

LoopVerdict placeGateVerdict(const PlaceGateOptions& options, double chi2) {
  if (chi2 <= options.chi2_threshold) return {};
  char why[96];
  std::snprintf(why, sizeof why, "place gate: too far apart for one place (statistic %.1f)", chi2);
  return {LoopRefusal::kPlaceGate, why};
}

std::string SlamOptions::validate() const {
  std::string error = place_gate.validate();
  if (!error.empty()) return "place_gate: " + error;
  error = odometry.validate();
  if (!error.empty()) return "odometry: " + error;
  error = aligner.validate();
  if (!error.empty()) return "aligner: " + error;
  error = loops.validate();
  if (!error.empty()) return "loops: " + error;
  error = esdf.validate();
  if (!error.empty()) return "esdf: " + error;
  error = consensus.validate();
  if (!error.empty()) return "consensus: " + error;
  return "";
}

SlamPipeline::SlamPipeline(const ClassifierModel& model, const SlamOptions& options)
    : options_(checked(options)),
      front_(model, options.odometry, options.aligner, options.loops),
      back_(options.esdf, options.gate_loops, options.consensus) {}

SlamCounters SlamPipeline::counters() const {
  const FrontEndCounters& f = front_.counters();
  const BackEndCounters& b = back_.counters();
  SlamCounters c;
  c.scans = f.scans, c.skipped_scans = f.skipped_scans, c.keyframes = b.keyframes;
  c.scans_skipped = f.scans_skipped, c.steps_not_matched = f.steps_not_matched;
  c.matched_steps = f.matched_steps, c.wheel_steps = f.wheel_steps, c.disputed_steps = f.disputed_steps;
  c.recovered_steps = f.recovered_steps, c.realigned_steps = f.realigned_steps;
  c.tracked_steps = f.tracked_steps;
  c.wheel_jumps = f.wheel_jumps, c.time_jumps = f.time_jumps, c.stalled_wheel_scans = f.stalled_wheel_scans;
  c.laser_fallback_steps = f.laser_fallback_steps, c.scans_counted = f.scans_counted;
  c.ambiguous_steps = f.ambiguous_steps, c.scans_placed_by_prediction = f.scans_placed_by_prediction;
  c.pairs_classified = f.pairs_classified, c.candidates = f.candidates, c.aligned = f.aligned;
  c.nearby_aligned = f.nearby_aligned, c.nearby_found = f.nearby_found;
  c.context_checked = f.context_checked, c.context_unchecked = f.context_unchecked;
  c.refused_by_context = f.refused_by_context, c.seconds_context = f.seconds_context;
  c.loops_accepted = b.loops_accepted, c.refused_by_alignment = f.refused_by_alignment;
  c.refused_by_gate = b.refused_by_gate, c.not_aligned = f.not_aligned;
  c.applied_by_consensus = b.applied_by_consensus;
  c.calibration_pairs = f.calibration_pairs, c.classifier_threshold = front_.detector().threshold();
  c.seconds_odometry = f.seconds_odometry, c.seconds_classify = f.seconds_classify;
  c.seconds_align = f.seconds_align, c.seconds_backend = b.seconds;
  return c;
}

std::vector<ScanPose> SlamPipeline::scanPoses() const {
  std::vector<ScanPose> scans;
  scans.reserve(placements_.size());
  const std::vector<Pose2>& keyframes = poses();
  for (const Placement& p : placements_)
    if (p.keyframe < keyframes.size()) scans.push_back({p.scan_index, p.stamp, p.keyframe, compose(keyframes[p.keyframe], p.offset)});
  return scans;
}

SlamStepResult SlamPipeline::addScan(const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry) {
  FrontEndStep front = front_.addScan(scan, wheel_odometry);
  SlamStepResult step;
  step.skip_reason = std::move(front.skip_reason);
  step.skip = front.skip;
  step.wheel_jump = std::move(front.wheel_jump);
  step.time_jump = std::move(front.time_jump);
  if (front.skip == ScanRefusal::kNone && front_.keyframeCount() > 0)
    placements_.push_back({scan_index, scan.stamp, front.keyframe ? front.keyframe_index : front_.keyframeCount() - 1,
                           front.keyframe ? Pose2{} : front.odometry.motion});
  if (!front.keyframe) return step;
  step.keyframe = true;
  step.keyframe_index = front.keyframe_index;
  step.odometry = front.odometry;

  // The back end keeps every keyframe, so the indices stay the front end's.
  step.back_end_note = back_.addKeyframe(makeKeyframe(scan, scan_index, wheel_odometry), step.odometry.motion, step.odometry.covariance);

  CandidateCheck place_gate;
  if (options_.place_gate.enabled) {
    place_gate = [this](std::size_t from, std::size_t to) {
      return placeGateVerdict(options_.place_gate, back_.placeChi2(from, to, options_.place_gate.radius));
    };
  }
  const NearbyKeyframes nearby = [this](std::size_t index, std::size_t before, double max_distance, double max_std,
                                        std::size_t count) {
    return back_.nearbyKeyframes(index, before, max_distance, max_std, count);
  };
  step.loops = front_.detectLoops(step.keyframe_index, place_gate, nearby);

  for (const LoopClosure& loop : step.loops.aligned) {
    LoopRecord record;
    if (loop.accepted) {
      record = back_.addLoop(loop);
      // Loops refused earlier that this one completed a consensus with: applied now. (This
      // one is the last and not in loops_ yet: `record` already says so.)
      for (std::size_t id : back_.lastConsensus())
        if (id < pipeline_index_of_.size()) loops_[pipeline_index_of_[id]] = back_.loops()[id];
      pipeline_index_of_.push_back(loops_.size());
    } else {
      record.loop = loop;
      record.refusal = loop.refusal;
      record.reject_reason = loop.reject_reason;
    }
    step.records.push_back(record);
    loops_.push_back(std::move(record));
  }
  return step;
}

SlamStepResult SlamPipeline::addKeyframe(Keyframe keyframe, const std::vector<double>& features,
                                         const OdometryStep& odometry) {
  SlamStepResult step;
  step.keyframe = true;
  step.keyframe_index = front_.addKeyframeMadeElsewhere(keyframe.scan, features, odometry.motion);
  step.odometry = odometry;
  placements_.push_back({keyframe.scan_index, keyframe.stamp, step.keyframe_index, Pose2{}});
  step.back_end_note = back_.addKeyframe(std::move(keyframe), odometry.motion, odometry.covariance);
  return step;
}

LoopRecord SlamPipeline::addLoop(const LoopClosure& loop) {
  LoopRecord record;
  if (!loop.accepted) {  // refused by the front end's alignment: recorded, never applied (as addScan)
    record.loop = loop;
    record.refusal = loop.refusal;
    record.reject_reason = loop.reject_reason;
    loops_.push_back(record);
    return record;
  }
  // The back end refuses one naming a keyframe it does not hold (malformed), and records it.
  record = back_.addLoop(loop);
  for (std::size_t id : back_.lastConsensus())
    if (id < pipeline_index_of_.size()) loops_[pipeline_index_of_[id]] = back_.loops()[id];
  pipeline_index_of_.push_back(loops_.size());
  loops_.push_back(record);
  return record;
}

SlamSession SlamPipeline::session() const {
  std::vector<std::vector<double>> features;
  for (std::size_t k = 0; k < front_.keyframeCount(); ++k) features.push_back(front_.detector().features(k));
  return sessionOf(back_, features, &robots_);
}

std::string SlamPipeline::restore(const SlamSession& session, bool continue_odometry) {
  const std::string invalid = session.validate();
  if (!invalid.empty()) return invalid;
  // The back end first: it is the one that can still refuse (a graph that cannot be rebuilt).
  std::string error = back_.restore(session);
  if (!error.empty()) return error;
  // Each keyframe's measured odometry step: the first constraint from the keyframe before it
  // (added with the keyframe, before any loop), unless it is a loose link (none measured).
  const double loose_information = 1.0 / looseLinkCovariance()(0, 0);  // its x variance, diagonal
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Pose2> steps(session.keyframes.size(), Pose2{nan, nan, nan});
  std::vector<char> seen(session.keyframes.size(), 0);
  for (const PoseEdge& edge : session.constraints) {
    if (edge.to != edge.from + 1 || edge.to >= steps.size() || seen[edge.to]) continue;
    seen[edge.to] = 1;
    if (edge.information(0, 0) > 2.0 * loose_information) steps[edge.to] = edge.measurement;
  }
  error = front_.restore(session.keyframes, session.features, continue_odometry, nullptr, &steps);
  if (!error.empty()) {  // after the back end took it: the map is left empty, not half restored
    (void)back_.restore(SlamSession{});
    return error;
  }
  loops_ = session.loops;
  robots_ = KeyframeRobots::afterRestore(session, continue_odometry);
  pipeline_index_of_.resize(loops_.size());
  for (std::size_t i = 0; i < loops_.size(); ++i) pipeline_index_of_[i] = i;  // a session holds the back end's loops only
  placements_.clear();  // the scans of another run: their keyframes are gone
  return "";
}

}  // namespace llc
