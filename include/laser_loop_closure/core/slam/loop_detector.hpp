// Loop detection for one new keyframe: the classifier against every stored keyframe older than
// min_keyframe_gap (no pose prior), then the best candidates aligned with no initial guess
// (CRF-match, ICP) and shape-validated. One class for the nodelet and `llc slam`.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/classifier/keyframe_store.hpp"
#include "laser_loop_closure/core/alignment/context_check.hpp"
#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/classifier/threshold_calibration.hpp"
#include "laser_loop_closure/core/slam/prepared_scan_cache.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct LoopDetectorOptions {
  std::size_t min_keyframe_gap = 30;  ///< keyframes; the most recent ones are never loop candidates
  std::size_t max_candidates = 3;     ///< candidates (score >= threshold) aligned per keyframe, best first
  /// Candidates a CandidateCheck (the place gate) looks at, best first, to find max_candidates
  /// it lets through: a refused one frees its slot for the next. 0: max_candidates (a refused
  /// one's slot stays empty). More closes more revisits, and lets more aliased places through.
  std::size_t checked_candidates = 0;
  double score_threshold = 0.0;       ///< on the normalised score; 0 = the model's K
  bool stop_at_first_accepted = true;  ///< align no further candidate once one is accepted
  /// Keyframes the map puts near the new one, aligned (no initial guess, as any candidate)
  /// when the classifier's candidates gave no loop: the classifier misses places of a
  /// building it never saw, the map's estimate does not. 0: the classifier alone (the paper).
  std::size_t nearby_candidates = 2;
  double nearby_distance = 5.0;  ///< m; how far apart the map may put a nearby keyframe (its estimate, not a test)
  /// m; only keyframes whose position relative to the new one the map knows this well (largest
  /// standard deviation): where it does not, a look-alike place nearby is aligned as readily.
  double nearby_max_std = 1.0;
  /// A nearby keyframe is first aligned by ICP from where the map puts the new one; when that
  /// fits (ScanAligner::fit) below this, it is refused without the search with no guess (a
  /// keyframe near on the map that does not see the same place, most of them: cheap to tell).
  /// 0: every nearby keyframe searched.
  double nearby_min_predicted_fit = 0.3;
  std::size_t threads = 1;            ///< threads of the classifier query
  /// Keyframes kept prepared for alignment (points, normals, search structures: most of a
  /// keyframe's memory), the most recently aligned; the others keep their scan and are prepared
  /// again when aligned, with the same result. 0: every keyframe kept prepared.
  std::size_t prepared_cache = 300;
  /// Floors added to ICP's covariance of a loop (which only knows the residuals, and is
  /// optimistic): standard deviations, as the back end's chi-square gate sees them.
  double translation_sigma = 0.05;  ///< m
  double rotation_sigma = 0.01;     ///< rad
  /// K fitted again in this building from surely-different keyframe pairs (used only when
  /// score_threshold is 0, i.e. the model's K would be used).
  ThresholdCalibrationOptions calibration{};
  /// A shape-validated loop is refused when the keyframes around its two keyframes fit
  /// clearly better at a look-alike pose (detect() with a KeyframeContext source).
  ContextCheckOptions context{};
  [[nodiscard]] std::string validate() const;
};

struct LoopDetectionResult {
  std::size_t keyframe = 0;
  std::size_t compared = 0;    ///< stored keyframes the classifier saw
  std::size_t candidates = 0;  ///< of those, at or above the threshold (at most checked_candidates kept)
  std::size_t nearby = 0;      ///< of `aligned`, the keyframes a NearbyKeyframes source offered
  std::size_t context_checked = 0;    ///< shape-validated loops checked against their context
  std::size_t context_unchecked = 0;  ///< shape-validated loops whose context was too small to check
  double context_seconds = 0.0;       ///< of seconds, in the context check
  std::vector<LoopClosure> aligned;  ///< in the order tried (best score first)
  /// Candidates a CandidateCheck refused before alignment (refusal and reject_reason say why; no pose).
  std::vector<LoopClosure> not_aligned;
  double classify_seconds = 0.0, check_seconds = 0.0, seconds = 0.0;  ///< check: inside CandidateCheck
};

/// Asked before a candidate pair (from, to) is aligned: not refused to align it, else why not
/// (e.g. the back end says the two keyframes cannot be at one place). Detection itself needs none.
using CandidateCheck = std::function<LoopVerdict(std::size_t from, std::size_t to)>;

/// Asked for keyframes older than `before` that the map puts within `max_distance` of keyframe
/// `index`, their relative position known to `max_std`, nearest first, at most `count` (e.g.
/// SlamBackEnd::nearbyKeyframes).
using NearbyKeyframes = std::function<std::vector<NearbyKeyframe>(std::size_t index, std::size_t before, double max_distance,
                                                                  double max_std, std::size_t count)>;

/// A keyframe of a context and its pose in the frame of the keyframe it surrounds.
struct ContextKeyframe {
  std::size_t keyframe = 0;
  Pose2 pose;
};
/// Asked for the context of keyframe `index`: itself (first, at the identity) and the
/// keyframes of its odometry chain older than `before` within `distance` m of driven path,
/// at least `spacing` m of path apart, each placed by that chain (SlamFrontEnd's).
using KeyframeContext =
    std::function<std::vector<ContextKeyframe>(std::size_t index, std::size_t before, double distance, double spacing)>;

class LoopDetector {
 public:
  /// Throws std::invalid_argument on bad options or a model whose features differ from
  /// what the extractor can compute.
  LoopDetector(const ClassifierModel& model, const ScanAlignerOptions& aligner,
               const LoopDetectorOptions& options = {});

  const LoopDetectorOptions& options() const { return options_; }
  const ScanAligner& aligner() const { return aligner_; }
  const ClassifierModel& model() const { return model_; }
  std::size_t size() const { return prepared_.size(); }
  /// Keyframes prepared now, and scans prepared again after the cache let them go.
  std::size_t heldPrepared() const { return prepared_.heldPrepared(); }
  std::size_t preparedAgain() const { return prepared_.preparedAgain(); }
  /// Bytes of the keyframes' scans kept to prepare again, and of their stored features.
  std::size_t scanBytes() const { return prepared_.restingBytes(); }
  std::size_t featureBytes() const { return store_.bytes(); }
  /// Values in each stored feature vector (what addWithFeatures takes).
  std::size_t featureCount() const { return store_.featureCount(); }

  /// Stores a keyframe: its features and its scan prepared for alignment (prepared by
  /// aligner(), or nullptr to prepare it when first aligned; with prepared_cache 0, here); with
  /// prepared_cache > 0 it keeps a copy of the scan to prepare it again. Returns its index.
  std::size_t add(const Scan& scan, std::shared_ptr<const PreparedScan> prepared = nullptr);
  /// Stores a keyframe whose features are already known (a loaded session, a keyframe made
  /// elsewhere): `prepared` (by aligner()) and/or `scan` (to prepare it when needed; without
  /// it, the prepared scan is kept for ever). Throws std::invalid_argument when both are null.
  std::size_t addWithFeatures(const std::vector<double>& features, std::shared_ptr<const PreparedScan> prepared,
                              const Scan* scan = nullptr);
  /// Classifies keyframe `index` against every keyframe older than min_keyframe_gap and aligns
  /// the best candidates, each after `check` (when given) let it through. When none gave a
  /// loop, the keyframes `nearby` (when given) offers are checked and aligned the same way
  /// (nearby_candidates of them, not aligned twice). With `context` (and options().context
  /// enabled) a shape-validated loop is then checked against the keyframes around it
  /// (checkLoopContext); a refused one reads "context: ...". Throws std::out_of_range for an
  /// unknown keyframe.
  LoopDetectionResult detect(std::size_t index, const CandidateCheck& check = {}, const NearbyKeyframes& nearby = {},
                             const KeyframeContext& context = {}) const;
  /// Aligns one pair (from, to) and validates it, as detect() does for a candidate.
  LoopClosure verify(std::size_t from, std::size_t to, double score) const;
  /// A scan that is not stored (a robot finding itself on a saved map): classified against
  /// every stored keyframe with no pose prior, and the best `max_candidates` at or above the
  /// threshold aligned with no guess and shape-validated, each of them (no nearby keyframes,
  /// no context check). The loops read from = the stored keyframe, to = `to` (the caller's
  /// name for the scan). Throws std::invalid_argument for features of another length.
  /// `threshold` > 0 takes the place of the K candidates must reach; `threads` > 1 aligns the
  /// candidates on that many threads (the same loops, in the same order). `check` (when given)
  /// is asked before each candidate is aligned; one it refuses goes to not_aligned, its slot empty.
  LoopDetectionResult detectScan(const std::vector<double>& features, const PreparedScan& scan, std::size_t to,
                                 std::size_t max_candidates, double threshold = 0.0, std::size_t threads = 1,
                                 const CandidateCheck& check = {}) const;
  /// verifyScan() of each stored keyframe in `from` (scores 0) with the scan, on `threads`
  /// threads; the loops in the order of `from`. What detectScan aligns its candidates with, and
  /// what a localiser given a pose hint aligns the keyframes near it with.
  std::vector<LoopClosure> verifyScans(const std::vector<std::size_t>& from, const PreparedScan& scan, std::size_t to,
                                       std::size_t threads, const std::vector<double>& scores = {}) const;
  /// verify() of stored keyframe `from` and a scan that is not stored, named `to`;
  /// `second_thread` as in ScanAligner::align (false when the caller aligns pairs side by side).
  LoopClosure verifyScan(std::size_t from, const PreparedScan& scan, std::size_t to, double score,
                         bool second_thread = true) const;
  /// A nearby keyframe: ICP from where the map puts `to` in `from`'s frame; below
  /// nearby_min_predicted_fit refused (validation), else verify()'s search with no guess.
  LoopClosure verifyFromPrediction(std::size_t from, std::size_t to, double score, const Pose2& predicted) const;

  std::vector<double> features(std::size_t index) const { return store_.features(index); }
  /// The feature vector the detector would store for this scan.
  std::vector<double> describe(const Scan& scan) { return extractor_.extract(scan); }
  /// Throws std::out_of_range for an unknown keyframe or one whose scan was let go. Prepares
  /// it again when the cache let it go; the reference stays valid until the next add (or
  /// other non-const call), as PreparedScanCache says. Safe from several threads.
  const PreparedScan& prepared(std::size_t index) const { return prepared_.get(index, aligner_); }
  /// Lets go of the least recently aligned prepared scans beyond prepared_cache (add() does it;
  /// a store that takes no more keyframes, a localiser's map, calls it between its steps).
  void trimPrepared() { prepared_.trim(); }
  /// Lets go of keyframe `index`'s prepared scan (points, normals, search structures: most of
  /// a keyframe's memory); its features stay, so it is still classified and counted, but it
  /// can no longer be aligned. For stores whose old keyframes are never aligned again (a
  /// localising robot's own). Unknown indices are ignored.
  void releasePrepared(std::size_t index);
  bool hasPrepared(std::size_t index) const { return prepared_.has(index); }
  /// Swaps in another model of the same feature parameters; throws std::invalid_argument else.
  /// The calibration starts again (its scores were the old model's).
  void setModel(const ClassifierModel& model);

  /// The classifier's score of keyframe `query` against keyframe `stored`, as detect() scores
  /// it. Throws std::out_of_range.
  double pairScore(std::size_t stored, std::size_t query) const;
  /// Feeds the calibration the scores of keyframe `index` against `surely_elsewhere` (older
  /// keyframes the odometry puts surely at other places) and applies the calibrated K when
  /// score_threshold is 0. Returns how many pairs were scored.
  std::size_t calibrate(std::size_t index, const std::vector<std::size_t>& surely_elsewhere);
  /// The K candidates must reach now.
  double threshold() const { return classifier_.thresholdK(); }
  const ThresholdCalibrator& calibrator() const { return calibrator_; }
  /// The context check of a shape-validated loop from this store's keyframe loop.from (its
  /// context from `context`, keyframes older than `before`) to keyframe loop.to of `new_store`
  /// (its context from `new_context`, itself and older): another robot's, or this store again.
  /// Refuses the loop in place (refusal kContext) when the context fits better elsewhere.
  ContextCheckResult checkContextWith(LoopClosure& loop, std::size_t before, const KeyframeContext& context,
                                      const LoopDetector& new_store, const KeyframeContext& new_context) const;

 private:
  /// The context check of a shape-validated loop (from older than `before`, to the newer);
  /// refuses it in place when the context fits better elsewhere.
  ContextCheckResult checkContext(LoopClosure& loop, std::size_t before, const KeyframeContext& context) const;

  ClassifierModel model_;
  StrongClassifier classifier_;  ///< the model's, with score_threshold applied
  LoopDetectorOptions options_;
  ScanAligner aligner_;
  FeatureExtractor extractor_;
  KeyframeStore store_;
  PreparedScanCache prepared_;
  ThresholdCalibrator calibrator_;
};

/// A covariance of a small motion applied in the target frame (ICP's) as the covariance of
/// the pose's own x, y, theta: J C J^T with J the Jacobian of exp(delta) * pose.
Eigen::Matrix3d poseParameterCovariance(const Pose2& pose, const Eigen::Matrix3d& target_frame_covariance);

/// A loop's covariance as the back end gets it: ICP's (poseParameterCovariance) plus the floors
/// translation_sigma and rotation_sigma of `options`.
Eigen::Matrix3d loopCovariance(const Pose2& pose, const Eigen::Matrix3d& icp_covariance, const LoopDetectorOptions& options);

}  // namespace llc
