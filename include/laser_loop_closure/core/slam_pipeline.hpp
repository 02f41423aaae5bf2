// The whole data path of ../shared/ARCHITECTURE.md for one robot: scans in, keyframes with
// scan-matching odometry, loop detection with no pose prior, and the ESDF back end. The
// nodelets and `llc slam` both drive this class; nothing here knows about ROS.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/esdf.hpp"
#include "laser_loop_closure/core/loop_detector.hpp"
#include "laser_loop_closure/core/scan_odometry.hpp"

namespace llc {

struct SlamOptions {
  ScanOdometryOptions odometry{};
  ScanAlignerOptions aligner{};
  LoopDetectorOptions loops{};
  EsdfOptions esdf{};
  bool gate_loops = true;  ///< chi-square test of each loop's innovation in the back end before it is applied
  std::string validate() const;  ///< names the stage whose option is wrong
};

/// A keyframe as the map and the session keep it.
struct Keyframe {
  std::size_t scan_index = 0;  ///< the caller's index of the scan it was made from
  double stamp = 0.0;          ///< s
  Scan scan;                   ///< in the base frame
  Pose2 wheel_odometry;        ///< in the odometry frame (when has_wheel_odometry)
  bool has_wheel_odometry = false;
};

/// One loop as the back end met it.
struct LoopRecord {
  LoopClosure loop;
  bool applied = false;          ///< accepted by alignment and by the back end's gate
  double innovation_chi2 = 0.0;  ///< when it reached the back end
  std::string reject_reason;     ///< the aligner's or the back end's; empty when applied
};

/// Counts of every decision since the start.
struct SlamCounters {
  std::size_t scans = 0, skipped_scans = 0, keyframes = 0;
  std::size_t matched_steps = 0, wheel_steps = 0;  ///< odometry constraints by ICP / from the guess alone
  std::size_t pairs_classified = 0, candidates = 0, aligned = 0;
  std::size_t loops_accepted = 0;        ///< applied to the back end
  std::size_t refused_by_alignment = 0;  ///< CRF-match, ICP or shape validation said no
  std::size_t refused_by_gate = 0;       ///< the back end's chi-square test said no
  double seconds_odometry = 0.0, seconds_classify = 0.0, seconds_align = 0.0, seconds_backend = 0.0;
};

/// What one scan did.
struct SlamStepResult {
  bool keyframe = false;
  std::size_t keyframe_index = 0;
  OdometryStep odometry;        ///< when keyframe (and not the first one)
  LoopDetectionResult loops;    ///< when keyframe
  std::vector<LoopRecord> records;  ///< the loops of this keyframe as the back end met them
  std::string skip_reason;      ///< non-empty: the scan was not used (and why)
};

class SlamPipeline {
 public:
  /// Throws std::invalid_argument on bad options or a model the extractor cannot serve.
  SlamPipeline(const ClassifierModel& model, const SlamOptions& options = {});

  /// Feeds one scan (base frame) with the wheel-odometry pose at its stamp when there is one.
  /// A scan older than the last keyframe's, or with a non-finite stamp or odometry, is skipped
  /// (skip_reason says why); never throws on bad data.
  SlamStepResult addScan(const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry);

  const SlamOptions& options() const { return options_; }
  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  /// Optimised keyframe poses in the map frame (the first keyframe sits at its wheel-odometry pose).
  const std::vector<Pose2>& poses() const;
  const std::vector<LoopRecord>& loops() const { return loops_; }
  const SlamCounters& counters() const { return counters_; }
  /// The map -> odom transform (REP-105) implied by the newest keyframe; identity without odometry.
  Pose2 mapToOdom() const;
  Esdf& backend() { return *esdf_; }
  LoopDetector& detector() { return detector_; }

 private:
  SlamOptions options_;
  ScanOdometry odometry_;
  LoopDetector detector_;
  std::unique_ptr<Esdf> esdf_;
  std::vector<Keyframe> keyframes_;
  std::vector<LoopRecord> loops_;
  SlamCounters counters_;
  /// Applies a loop the aligner accepted (through the gate); fills the record.
  void applyLoop(LoopRecord* record);
  Pose2 tracked_motion_;  ///< without wheel odometry: the last scan's motion from the newest keyframe
};

}  // namespace llc
