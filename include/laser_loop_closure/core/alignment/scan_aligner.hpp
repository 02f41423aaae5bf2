// The alignment stage of a loop-closure candidate: CRF-match (no initial guess), then ICP,
// then shape validation. One class for the nodelet and the offline tools.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/crf_match.hpp"
#include "laser_loop_closure/core/alignment/global_search.hpp"
#include "laser_loop_closure/core/alignment/icp.hpp"
#include "laser_loop_closure/core/alignment/shape_validation.hpp"

namespace llc {

struct ScanAlignerOptions {
  double max_range = 40.0;  ///< m; returns at or beyond this are not aligned (sparse, noisy)
  double selection_distance = 0.1;  ///< m; of several ICP results, the one with most points this near (both ways, in view) wins
  double reverse_below = 0.6;  ///< best such share below this: CRF-match b to a as well, for more starts (1 = always)
  bool parallel = true;  ///< match the other way round on a second thread meanwhile (same result, less wall time)
  /// ICP also from the starts of the global search (orientation histograms and translation
  /// votes) when no start so far converged, or the best share is still below this after
  /// CRF-match both ways (0 = only when none converged, 1 = always). More starts align more
  /// true matches, and more false ones, which the position test of validation refuses: see the README.
  double global_search_below = 0.7;
  /// Of the converged results, only those whose overlap (the points each scanner could have
  /// seen of the other, both ways) is at least this share of the largest overlap among them
  /// compete on the share: a pose that leaves few points in view can fit those few well.
  double min_relative_overlap = 0.6;
  /// ICP also from the winner shifted along the larger axis of its position covariance (along
  /// a corridor, where the local optima line up) by ±shift, ±2 shift, ±4 shift, ...:
  /// weak_direction_restarts of each sign (0 = none).
  double weak_direction_shift = 0.25;  ///< m
  int weak_direction_restarts = 3;
  double weak_direction_above = 0.6;  ///< only when the winner's share is at least this (most candidates are two places)
  CrfMatchOptions crf{};
  GlobalSearchOptions global{};
  IcpOptions icp{};
  ShapeValidationOptions validation{};
  [[nodiscard]] std::string validate() const;  ///< names the stage whose option is wrong
};

/// What ICP from a guess and shape validation need of a scan (scan-matching odometry's target,
/// e.g. a local map of several keyframes, which no search with no guess ever aligns).
struct MatchTarget {
  MatchTarget(Points2 points, const IcpOptions& icp, const FieldOfView& view = {});
  Points2 points;
  FieldOfView view;     ///< what its scanner could see (for shape validation)
  IcpTarget icp_target;  ///< its k-d tree also serves shape validation
};

/// Everything the aligner needs of one scan, computed once (a keyframe keeps it): a
/// MatchTarget, and the descriptors of the searches with no guess.
struct PreparedScan : MatchTarget {
  PreparedScan(Points2 points, const ScanAlignerOptions& options, const FieldOfView& view = {});
  CrfScan crf;
  GlobalSearchScan global;  ///< thinned points and normal directions (from icp_target's normals)
  FreeSpace free_space;  ///< where its beams ended (prepare() fills it when the seen-through test is on)
};

/// The stage of align() that refused a pair.
enum class AlignmentRefusal {
  kNone,        ///< accepted
  kNoStart,     ///< neither CRF-match nor the global search gave ICP a start
  kIcp,         ///< ICP converged from no start
  kValidation,  ///< aligned, but shape validation (or a test beyond the paper's) refused it
};
/// "none", "no_start", "icp", "validation".
const char* alignmentRefusalName(AlignmentRefusal refusal);

struct ScanAlignmentResult {
  bool accepted = false;     ///< aligned and shape-validated
  AlignmentRefusal refusal = AlignmentRefusal::kNone;  ///< which stage refused it (what decisions read)
  Pose2 pose;                ///< scan b in the frame of scan a (valid when icp.converged)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of pose, from ICP
  CrfMatchResult crf;
  GlobalSearchResult global;  ///< empty unless the global search ran
  IcpResult icp;
  ShapeValidationResult validation;
  /// Every converged ICP result (one per start) and its share of points within
  /// selection_distance: what the winner was chosen from.
  std::vector<Pose2> icp_poses;
  std::vector<double> icp_shares;
  std::size_t chosen = 0;  ///< index in icp_poses / icp_shares of the result that went on to validation
  double seconds = 0.0;      ///< all stages
  std::string reject_reason;  ///< the same for people: "crf: ...", "icp: ..." or "validation: ..."; empty when accepted
};

class ScanAligner {
 public:
  /// Throws std::invalid_argument when options.validate() finds a problem.
  explicit ScanAligner(const ScanAlignerOptions& options = {});
  const ScanAlignerOptions& options() const { return options_; }

  std::shared_ptr<const PreparedScan> prepare(const Scan& scan) const;
  /// Aligns b to a with no initial guess.
  ScanAlignmentResult align(const PreparedScan& a, const PreparedScan& b) const { return align(a, b, true); }
  /// The same result; `second_thread` false keeps it on the calling thread whatever
  /// options().parallel says (for callers that already align several pairs side by side, where
  /// a second thread per pair only competes).
  ScanAlignmentResult align(const PreparedScan& a, const PreparedScan& b, bool second_thread) const;
  /// How well b placed at `pose` in a's frame fits a, as align() ranks its ICP results: the
  /// mean of the shares of b's points near a's and of a's points near b's (within
  /// selection_distance), each among the points the other scanner could have seen.
  double fit(const PreparedScan& a, const PreparedScan& b, const Pose2& pose) const;
  /// ICP of b onto a from `start`, as align() runs it from each of its starts.
  IcpResult refine(const PreparedScan& a, const PreparedScan& b, const Pose2& start) const;

 private:
  ScanAlignerOptions options_;
};

/// How well one ICP result fits, as align() ranks them.
struct AlignmentFit {
  double share = 0.0;       ///< mean of the two ways' shares of points within selection_distance
  std::size_t overlap = 0;  ///< points counted, both ways: those the other scanner could have seen
};
/// The index of the best share among the fits whose overlap is at least min_relative_overlap
/// of the largest (0 when fits is empty).
std::size_t pickAlignment(const std::vector<AlignmentFit>& fits, double min_relative_overlap);
/// Starts for restarts along the weakest direction: `pose` shifted both ways along the larger
/// axis of the x-y block of `covariance` by shift, 2 shift, 4 shift, ... (count of each sign,
/// nearest first, minus before plus); the heading is kept.
std::vector<Pose2> weakDirectionStarts(const Pose2& pose, const Eigen::Matrix3d& covariance, double shift, int count);

}  // namespace llc
