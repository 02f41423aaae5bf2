// The whole data path of ../shared/ARCHITECTURE.md for one robot: the front end (keyframes with
// scan-matching odometry, loop detection with no pose prior) joined directly to the ESDF back
// end. `llc slam` drives it; the nodelets run the two halves apart, joined by messages.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_front_end.hpp"

namespace llc {

/// Before a candidate is aligned, the back end's prediction of where its two keyframes are
/// (means and joint covariance) is asked whether they can be at one place (Esdf::placeChi2).
/// The classifier still sees every stored keyframe with no pose prior; this only spares the
/// alignment of candidates that the chi-square gate would refuse anyway.
struct PlaceGateOptions {
  bool enabled = true;            ///< false: align every candidate, as the paper does
  double radius = 3.0;            ///< m: how far apart two keyframes of one place lie (1 sigma per axis)
  double chi2_threshold = 13.82;  ///< 2 DoF (99.9%); a larger statistic: not aligned
  [[nodiscard]] std::string validate() const;
};

/// The place gate's verdict on a statistic: not refused (align it), or kPlaceGate and why it is
/// kept from alignment. One rule for `llc slam` and the nodelets.
LoopVerdict placeGateVerdict(const PlaceGateOptions& options, double chi2);

struct SlamOptions {
  ScanOdometryOptions odometry{};
  ScanAlignerOptions aligner{};
  LoopDetectorOptions loops{};
  EsdfOptions esdf{};
  bool gate_loops = true;  ///< chi-square test of each loop's innovation in the back end before it is applied
  LoopConsensusOptions consensus{};  ///< loops the gate refused, applied together once enough agree
  PlaceGateOptions place_gate{};
  [[nodiscard]] std::string validate() const;  ///< names the stage whose option is wrong
};

/// Counts of every decision since the start.
struct SlamCounters {
  std::size_t scans = 0, skipped_scans = 0, keyframes = 0;
  std::array<std::size_t, kScanRefusalKinds> scans_skipped{};          ///< by ScanRefusal
  std::array<std::size_t, kOdometryRefusalKinds> steps_not_matched{};  ///< keyframe steps by OdometryRefusal
  std::size_t matched_steps = 0, wheel_steps = 0;  ///< odometry constraints by ICP / from the guess alone
  std::size_t disputed_steps = 0;  ///< of the matched ones, ICP and wheels disagreed (covariance widened)
  std::size_t recovered_steps = 0;  ///< of the matched ones, the laser's motion from a correlative search over the wheels
  std::size_t realigned_steps = 0;  ///< of the matched ones, aligned with no guess where ICP overlapped little
  std::size_t tracked_steps = 0;    ///< of the matched ones, ICP from the tracked scans' pose (track_scans)
  std::size_t wheel_jumps = 0;     ///< wheel odometry that moved faster than any robot: left out
  std::size_t stalled_wheel_scans = 0;  ///< repeated wheel readings the laser contradicted: placed without them
  std::size_t laser_fallback_steps = 0;  ///< laser-placed scans matched from the last scan's pose, the prediction failing
  std::size_t scans_placed_by_prediction = 0;  ///< scans between keyframes disputed with the wheels, placed from the laser's prediction
  std::size_t ambiguous_steps = 0;  ///< laser-only keyframe steps widened along an ambiguous direction (ambiguity_score_drop)
  std::size_t scans_counted = 0;  ///< scans the motion model timed by counting (jittering stamps)
  std::size_t time_jumps = 0;      ///< stamps that jumped back: new odometry chains
  std::size_t pairs_classified = 0, candidates = 0, aligned = 0;
  std::size_t nearby_aligned = 0, nearby_found = 0;  ///< of aligned / of those accepted by alignment: nearby candidates
  std::size_t context_checked = 0, context_unchecked = 0;  ///< shape-validated loops checked against their context / too small to
  std::size_t refused_by_context = 0;    ///< shape-validated, then the context check said no
  std::size_t loops_accepted = 0;        ///< applied to the back end
  std::size_t refused_by_alignment = 0;  ///< CRF-match, ICP or shape validation said no
  std::size_t refused_by_gate = 0;       ///< the back end's chi-square test said no (and no consensus applied it later)
  std::size_t applied_by_consensus = 0;  ///< of loops_accepted, refused by the gate, then applied with others that agree
  std::size_t not_aligned = 0;           ///< candidates the place gate kept from alignment
  std::size_t calibration_pairs = 0;     ///< surely-different pairs scored for the threshold calibration
  double classifier_threshold = 0.0;     ///< the K candidates must reach now (calibrated or not)
  double seconds_odometry = 0.0, seconds_classify = 0.0, seconds_align = 0.0, seconds_backend = 0.0;
  double seconds_context = 0.0;  ///< of seconds_align, in the context check
};

/// What one scan did.
struct SlamStepResult {
  bool keyframe = false;
  std::size_t keyframe_index = 0;
  OdometryStep odometry;        ///< when keyframe (and not the first one)
  LoopDetectionResult loops;    ///< when keyframe: candidates aligned and not
  std::vector<LoopRecord> records;  ///< the loops of this keyframe as the back end met them
  std::string back_end_note;    ///< when keyframe: non-empty if the back end could not use its odometry as given (SlamBackEnd::addKeyframe)
  std::string skip_reason;      ///< non-empty: the scan was not used (and why)
  ScanRefusal skip = ScanRefusal::kNone;  ///< the same as a name
  std::string wheel_jump;       ///< non-empty: its wheel odometry jumped and was left out (FrontEndStep)
  std::string time_jump;        ///< non-empty: its stamp jumped back and it starts a new chain (FrontEndStep)
};

/// One scan's pose in the map: its keyframe's optimised pose carried by the scan's motion from
/// that keyframe (the wheels', or scan matching's without wheels).
struct ScanPose {
  std::size_t scan_index = 0;  ///< the caller's index of the scan
  double stamp = 0.0;          ///< s
  std::size_t keyframe = 0;    ///< the newest keyframe when the scan came
  Pose2 pose;                  ///< in the map frame
};

class SlamPipeline {
 public:
  /// Throws std::invalid_argument on bad options or a model the extractor cannot serve.
  SlamPipeline(const ClassifierModel& model, const SlamOptions& options = {});

  /// Feeds one scan (base frame) with the wheel-odometry pose at its stamp when there is one.
  /// A scan older than the last keyframe's, or with a non-finite stamp or odometry, is skipped
  /// (skip_reason says why); never throws on bad data.
  SlamStepResult addScan(const Scan& scan, std::size_t scan_index, const Pose2* wheel_odometry);

  /// A keyframe another front end made (a robot's loop_closure nodelet): stored for loop
  /// searches and the context check, and into the back end with its odometry step, as addScan
  /// would after its front end (no scan matched, no loop searched: its loops come by addLoop).
  /// Never throws on bad data; the back end's note says what of the odometry was unusable.
  SlamStepResult addKeyframe(Keyframe keyframe, const std::vector<double>& features, const OdometryStep& odometry);
  /// A loop that front end aligned between two of its keyframes already added: when accepted,
  /// to the back end (one naming a keyframe not added: refused as malformed); recorded with loops().
  LoopRecord addLoop(const LoopClosure& loop);

  const SlamOptions& options() const { return options_; }
  const std::vector<Keyframe>& keyframes() const { return back_.keyframes(); }
  /// Optimised keyframe poses in the map frame (the first keyframe sits at its wheel-odometry pose).
  const std::vector<Pose2>& poses() const { return back_.poses(); }
  /// Every aligned candidate: refused by alignment, refused by the gate, or applied.
  const std::vector<LoopRecord>& loops() const { return loops_; }
  SlamCounters counters() const;
  /// Every scan the front end used (not the skipped ones), in the order fed, placed from the
  /// current optimised keyframe poses.
  std::vector<ScanPose> scanPoses() const;
  /// The map -> odom transform (REP-105) implied by the newest keyframe; identity without odometry.
  Pose2 mapToOdom() const { return back_.mapToOdom(); }
  SlamBackEnd& backEnd() { return back_; }
  const SlamBackEnd& backEnd() const { return back_; }
  /// The state to save: keyframes, their features, the graph, the loops and who made each
  /// keyframe (KeyframeRobots: a restored session's robots, then this run's).
  SlamSession session() const;
  /// Restores both ends from a session (see SlamFrontEnd::restore for continue_odometry).
  /// Returns "" or why not, never throws: refused by the session's own checks or the back end,
  /// nothing changed; by the front end (a keyframe it cannot take), the map is left empty.
  [[nodiscard]] std::string restore(const SlamSession& session, bool continue_odometry);
  LoopDetector& detector() { return front_.detector(); }
  const LoopDetector& detector() const { return front_.detector(); }
  const SlamFrontEnd& frontEnd() const { return front_; }

 private:
  SlamOptions options_;
  SlamFrontEnd front_;
  SlamBackEnd back_;
  std::vector<LoopRecord> loops_;
  KeyframeRobots robots_;  ///< who made each keyframe (a restored session's, then this run's)
  std::vector<std::size_t> pipeline_index_of_;  ///< the back end's loop i is loops_[pipeline_index_of_[i]]
  /// Each used scan: its index, stamp, newest keyframe and motion from it (scanPoses).
  struct Placement {
    std::size_t scan_index;
    double stamp;
    std::size_t keyframe;
    Pose2 offset;
  };
  std::vector<Placement> placements_;
};

}  // namespace llc
