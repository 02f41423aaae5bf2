// The front end of ../shared/ARCHITECTURE.md: scans in; keyframes with scan-matching odometry
// and loop closures (classifier with no pose prior, then CRF-match/ICP/shape validation) out.
// The loop_closure nodelet runs it alone; SlamPipeline joins it to the back end directly.
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <vector>

#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/motion_clock.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"
#include "laser_loop_closure/core/slam/self_training.hpp"

namespace llc {

/// Counts of the front end's decisions since the start.
struct FrontEndCounters {
  std::size_t scans = 0, skipped_scans = 0, keyframes = 0;
  std::array<std::size_t, kScanRefusalKinds> scans_skipped{};          ///< by ScanRefusal
  std::array<std::size_t, kOdometryRefusalKinds> steps_not_matched{};  ///< keyframe steps by OdometryRefusal
  std::size_t matched_steps = 0, wheel_steps = 0;  ///< odometry steps by ICP / from the guess alone
  std::size_t disputed_steps = 0;  ///< of the matched ones, beyond max_wheel_disagreement (covariance widened)
  std::size_t recovered_steps = 0;  ///< of the matched ones, by correlative_recovery (the laser over the wheels)
  std::size_t realigned_steps = 0;  ///< of the matched ones, aligned with no guess where ICP overlapped little (realign_below_overlap)
  std::size_t tracked_steps = 0;    ///< of the matched ones, ICP from the tracked scans' pose (track_scans)
  std::size_t wheel_jumps = 0;     ///< wheel odometry that moved faster than any robot: left out
  std::size_t stalled_wheel_scans = 0;  ///< scans whose repeated wheel reading the laser contradicted: placed without it
  std::size_t laser_fallback_steps = 0;  ///< laser-placed scans whose ICP failed from the prediction and held from the last scan's pose
  std::size_t scans_placed_by_prediction = 0;  ///< scans between keyframes disputed with the wheels, placed by ICP from the laser's prediction
  std::size_t ambiguous_steps = 0;  ///< laser-only keyframe steps whose covariance was widened along an ambiguous direction (ambiguity_score_drop)
  std::size_t scans_counted = 0;  ///< scans whose motion time counted scans (their stamps jitter: MotionClock)
  std::size_t time_jumps = 0;      ///< stamps that jumped back (restart_after_jump_back): new chains
  std::size_t pairs_classified = 0, candidates = 0, aligned = 0;
  std::size_t nearby_aligned = 0;        ///< of `aligned`, keyframes the map put near (not the classifier)
  std::size_t nearby_found = 0;          ///< of those, aligned and shape-validated
  std::size_t context_checked = 0;       ///< shape-validated loops checked against their context
  std::size_t context_unchecked = 0;     ///< ... whose context was too small (e.g. a restored keyframe)
  std::size_t refused_by_context = 0;    ///< shape-validated, then refused by the context check
  std::size_t loops_found = 0;           ///< aligned, shape-validated and context-checked: sent to the back end
  std::size_t refused_by_alignment = 0;  ///< CRF-match, ICP or shape validation said no
  std::size_t not_aligned = 0;           ///< candidates a CandidateCheck kept from alignment
  std::size_t calibration_pairs = 0;     ///< surely-different pairs scored for the threshold calibration
  double seconds_odometry = 0.0, seconds_classify = 0.0, seconds_align = 0.0;
  double seconds_context = 0.0;  ///< of seconds_align, in the context check
};

/// What one scan did in the front end.
struct FrontEndStep {
  bool keyframe = false;
  std::size_t keyframe_index = 0;
  /// From the previous keyframe (when keyframe and not the first). For a scan that is not a
  /// keyframe, motion is its pose relative to the newest keyframe: the wheels' guess, or
  /// scan matching's without wheels.
  OdometryStep odometry;
  /// The scan's pose in the front end's own odometry frame: its matched motions chained from
  /// the first keyframe (a new chain after a restore or a time jump goes on from where the
  /// last one ended, so the frame never jumps). What a robot without wheels broadcasts as
  /// odom -> base_link. Set for every scan after the first keyframe.
  Pose2 odometry_pose;
  bool has_odometry_pose = false;
  std::string skip_reason;    ///< non-empty: the scan was not used (and why)
  ScanRefusal skip = ScanRefusal::kNone;  ///< the same as a name
  /// Non-empty: the wheel odometry jumped farther than max_speed allows since the scan before
  /// (what it did); that jump was left out of the motion.
  std::string wheel_jump;
  /// Non-empty: the scan was older than the newest keyframe by more than
  /// restart_after_jump_back, and starts a new odometry chain (what happened).
  std::string time_jump;
};

class SlamFrontEnd {
 public:
  /// Throws std::invalid_argument on bad options or a model the extractor cannot serve.
  SlamFrontEnd(const ClassifierModel& model, const ScanOdometryOptions& odometry,
               const ScanAlignerOptions& aligner, const LoopDetectorOptions& loops);

  /// Feeds one scan (base frame) with the wheel-odometry pose at its stamp when there is one.
  /// A scan older than the last keyframe, with a non-finite stamp or odometry, or with ranges
  /// and bearings of different lengths, is skipped (skip_reason says why); never throws on data.
  /// A new keyframe is only stored: detectLoops looks for its loops.
  FrontEndStep addScan(const Scan& scan, const Pose2* wheel_odometry);
  /// A keyframe another front end made (a robot's loop_closure nodelet, its message taken by a
  /// back end of several robots): stored for loop searches and the context check, its odometry
  /// chain extended by `motion` (from the keyframe before; non-finite: a new chain), the
  /// classifier's threshold calibrated as detectLoops does. No scan is matched, no loop searched. Features of another length than the model's are computed
  /// from the scan. Returns its index.
  std::size_t addKeyframeMadeElsewhere(const Scan& scan, const std::vector<double>& features, const Pose2& motion);
  /// Loop detection for a stored keyframe (LoopDetector::detect), counted. Two calls apart so
  /// that a back end can take the keyframe first and then answer `check`.
  LoopDetectionResult detectLoops(std::size_t keyframe_index, const CandidateCheck& check = {},
                                  const NearbyKeyframes& nearby = {});

  /// Replaces the keyframes by a saved session's: stored features are used when they are what
  /// this model's extractor makes (checked on the first keyframe), else recomputed from the
  /// scans. With continue_odometry the next scan is matched to the newest restored keyframe,
  /// seeded by wheel odometry (the robot and its odom frame went on); else it starts a new
  /// chain whose first keyframe is linked to the newest restored one by a motion of almost no
  /// information (restartCovariance), so that its first loop closure places it. Returns ""
  /// or why not (keyframes and features of different counts, feature vectors of different
  /// lengths, a scan whose ranges and bearings differ in count); then nothing changed. Never throws.
  /// steps (with continue_odometry): per keyframe, the odometry step from the one before
  /// (non-finite where none was measured), which places the restored local map as the run
  /// that saved it had it (local_map_keyframes).
  [[nodiscard]] std::string restore(const std::vector<Keyframe>& keyframes, const std::vector<std::vector<double>>& features,
                      bool continue_odometry, bool* features_recomputed = nullptr,
                      const std::vector<Pose2>* steps = nullptr);
  /// Covariance of the link between a restored session and a new chain (m^2, rad^2).
  static Eigen::Matrix3d restartCovariance();

  /// Self-training (the train_classifier service): the pairs of the keyframes the back end has
  /// placed, labelled by their optimised poses (selfTrainingSet with this front end's feature
  /// set, min_keyframe_gap and scans). Throws std::invalid_argument as selfTrainingSet does.
  SelfTrainingSet selfTrainingSet(const std::vector<Pose2>& optimised_poses) const;

  /// Lets go of the prepared scans of keyframes before `keyframe` (LoopDetector::releasePrepared),
  /// but never of the newest local_map_keyframes, which odometry matches against. For a front
  /// end whose loops are not searched among its own keyframes (the localiser's): detectLoops,
  /// the context check and self-training would find those scans gone. Memory per keyframe then
  /// stays its features and pose. Returns how many were let go now.
  std::size_t releaseScansBefore(std::size_t keyframe);

  /// The KeyframeContext of the loop detector: keyframes of index's chain, placed by it (also
  /// the context of a loop between two robots' keyframes, each from its own front end).
  std::vector<ContextKeyframe> context(std::size_t index, std::size_t before, double distance, double spacing) const;

  std::size_t keyframeCount() const { return detector_.size(); }
  const FrontEndCounters& counters() const { return counters_; }
  LoopDetector& detector() { return detector_; }
  const LoopDetector& detector() const { return detector_; }

 private:
  // What the front end is made of (its options are theirs: odometry_.options(),
  // detector_.options(), detector_.aligner().options()).
  ScanOdometry odometry_;
  LoopDetector detector_;
  MotionClock motion_clock_;  ///< the scans' time as the motion model reads it
  WheelNoiseScale wheel_noise_;
  FrontEndCounters counters_;

  /// The newest keyframe as the odometry goes on from it. Reset as one where a chain ends (a
  /// restored session, time jumping back); set as one when a keyframe is made.
  struct KeyframeReference {
    bool exists = false;        ///< there is a newest keyframe to go on from
    double stamp = 0.0;         ///< its stamp
    bool has_wheels = false;    ///< it has a wheel reading to measure the next motion from
    Pose2 wheels;               ///< that reading (moved to leave a wheel jump out)
    bool restart_pending = false;  ///< the next keyframe starts a new chain (after a restore or a jump back)
    std::string restart_reason;    ///< why it does (the step's reject_reason)
  };
  KeyframeReference keyframe_;

  /// The wheel readings of the scans since (to see jumps and stalls). Reset as one where a chain
  /// ends: a jump is judged between scans of one run only.
  struct ScanWheels {
    bool has_last = false;
    Pose2 last;               ///< the scan before's reading
    double last_stamp = 0.0;
    bool moved = false;       ///< the last reading differed from the one before
    bool stalled = false;     ///< the last reading was found stalled (stalled_wheels_as_missing)
    /// The last jump, to tell a spike (the wheels come back) from a step: the reference and the
    /// reading before it (forgotten when a keyframe takes a new reference).
    bool has_jump = false;
    Pose2 before_jump_reference, before_jump_wheels;
    double before_jump_stamp = 0.0;
  };
  ScanWheels wheels_;

  /// The laser's own view of the motion: the last matched scan's motion from the newest
  /// keyframe and the velocity that predicts the next.
  struct MotionModel {
    double time = 0.0;       ///< the scan being added, on motion_clock_
    double last_time = 0.0;  ///< of track.motion, on motion_clock_
    /// The last matched velocity (per second, in the robot's frame), which predicts scans
    /// without (or with stalled) wheel odometry. Forgotten where a chain ends.
    Pose2 velocity;
    /// The last matched scan's motion from the newest keyframe: without wheel odometry every
    /// scan's; with wheels and match_every_scan the last scan ICP placed (has_wheels), with its
    /// wheel reading (the next guess goes on from there by the wheels). Reset as one at every keyframe.
    struct Track {
      Pose2 motion;
      Pose2 wheels;
      bool has_wheels = false;
    } track;
    /// Where a chain ends: nothing tracked, no velocity.
    void newChain() { track = {}, velocity = Pose2{}; }
  };
  MotionModel motion_;

  /// The threshold calibration's and the context check's view of the drive: each keyframe's
  /// pose by this front end's own odometry and the length driven to it. Keyframes before
  /// `start` (a restored session started anew) have no place in this chain; a session
  /// continued (restore with its steps) goes on in the chain it saved. Made as one by restore.
  struct KeyframeChains {
    std::vector<Pose2> pose;
    std::vector<double> path;
    std::vector<std::size_t> first;  ///< per keyframe, the first keyframe of its chain (restored ones: itself)
    std::size_t start = 0;
    bool full_circle = true;         ///< every keyframe's scan covers 360 degrees
  };
  KeyframeChains chains_;
  /// Keyframe `keyframe` (the newest) enters the chains, `motion` from the one before.
  void extendChains(std::size_t keyframe, const Pose2& motion, bool full_circle);

  /// Made from the newest keyframes when first needed, forgotten as one by restore (another
  /// run's keyframe of the same index is another scan).
  struct KeyframeCaches {
    /// local_map_keyframes > 1: the newest keyframes of keyframe local_map_of's chain merged in
    /// its frame (null: fewer than two in its chain).
    std::shared_ptr<const MatchTarget> local_map;
    std::size_t local_map_of = std::size_t(-1);
    /// The newest keyframe's likelihood field (newestKeyframeField: widenAlongAmbiguity, the
    /// prediction's placement of a disputed scan).
    std::shared_ptr<const LikelihoodField> newest_field;
    std::size_t newest_field_of = std::size_t(-1);
    /// releaseScansBefore's progress: keyframes below it hold no prepared scan in detector_.
    std::size_t released_before = 0;
  };
  KeyframeCaches caches_;

  /// The newest keyframe in the front end's own odometry frame, which goes on through new
  /// chains (what publish_odometry_tf broadcasts): never reset.
  struct OwnOdometry {
    Pose2 keyframe;
    bool has_keyframe = false;
  };
  OwnOdometry own_odometry_;
  Random calibration_random_{1};

  enum class WheelPlacement { kNotKeyframe, kKeyframe };
  /// The wheel odometry branch of addScan (the newest keyframe has a wheel reading): jumps
  /// left out, ICP from the wheels' guess and the tracked one, stalled readings found; fills
  /// step.odometry (and `prepared` when it matched).
  WheelPlacement placeWithWheels(const Scan& scan, const Pose2& wheels, bool repeated, FrontEndStep& step,
                                 std::shared_ptr<const PreparedScan>& prepared);
  /// The wheel reading of this scan, the next one's "scan before" (jumps, stalls).
  void rememberWheels(const Pose2& wheels, double stamp, bool repeated);
  /// tracked_motion_ carried on by velocity_ to motion_time_ (predict_motion, within max_prediction_gap).
  Pose2 predictedMotion() const;
  /// Whether predictedMotion() is a velocity's prediction (not the last pose standing in).
  bool predictsMotion() const;
  /// velocity_ from the tracked motion at last_motion_time_ to `motion` at motion_time_ (kept when
  /// the scans are min_velocity_interval apart and no faster than max_speed, max_turn_rate).
  void updateVelocity(const Pose2& motion);
  /// The scan is placed by the laser alone: ICP from the prediction, or from where the last
  /// scan stood when that fails (a prediction a bad step spoiled). Fills step.odometry.
  /// Without any wheels (`no_wheels`), the step's covariance also holds ICP's own, scaled
  /// (icp_covariance_scale).
  void placeByLaser(const PreparedScan& scan, bool no_wheels, FrontEndStep& step);
  /// A scan between keyframes whose ICP disputes the wheels: ICP from the laser's own prediction
  /// too, its result taken when it fits clearly better (selectSeed).
  void placeDisputedScanByPrediction(const PreparedScan& scan, const Pose2& wheel_guess, FrontEndStep& step);
  /// The newest keyframe's likelihood field (odometry/correlative's), built once per keyframe.
  std::shared_ptr<const LikelihoodField> newestKeyframeField();
  /// A keyframe step whose ICP overlaps little: aligned with no guess too (realign_below_overlap).
  void realignDoubtedStep(const PreparedScan& scan, const Pose2& wheel_guess, FrontEndStep& step);
  /// Fills step.odometry_pose from the newest keyframe's pose and the step's motion from it.
  void setOdometryPose(FrontEndStep& step) const;
  /// What a keyframe step with wheels is matched to: the newest keyframe's local map, or the
  /// newest keyframe alone.
  const MatchTarget& keyframeStepTarget();
  /// Older keyframes of this chain that the odometry puts surely elsewhere than `index` (at
  /// most calibration.pairs_per_keyframe, drawn at random when there are more).
  std::vector<std::size_t> surelyElsewhere(std::size_t index);
};

}  // namespace llc
