// Localisation on a saved map with no initial pose (issue 63). The robot is a trajectory of
// its own (../shared/ARCHITECTURE.md): the same front end as in mapping gives its keyframes
// and scan-matching odometry in its own frame. While lost, each new keyframe is classified
// against every keyframe of the map with no pose prior, the best candidates are aligned and
// shape-validated, and TrajectoryJoin fixes the trajectory's frame in the map once the loops
// of several keyframes agree. Once fixed, each keyframe is matched to the map keyframes near
// where it is tracked; when they stop fitting, the robot is lost and searches again by
// itself. The map is never changed.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/slam_front_end.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/core/slam/trajectory_join.hpp"

namespace llc {

struct LocalizerOptions {
  std::size_t global_candidates = 20;  ///< classifier candidates aligned per keyframe while lost (each may give a loop)
  /// The normalised score those candidates must reach (0: the model's K, as in mapping); lower
  /// finds more places the model was not trained on, and more look-alikes for the checks below.
  double score_threshold = 0.0;
  std::size_t search_threads = 2;     ///< threads aligning those candidates (the classifier query takes loops/threads)
  /// Shape validation's N for those candidates (mapping keeps aligner/validation/min_inlier_share,
  /// 0.9): a saved map was recorded at another time, so parked cars, doors and people have
  /// moved, and a right candidate may keep fewer points within d. Several keyframes must still
  /// agree, fit and pass probation before a fix.
  double min_inlier_share = 0.85;
  /// Those candidates' alignment runs the global search (aligner/global_search_below) only
  /// when its best share is below this too (0: only when no start converged). A lost robot's
  /// candidates are mostly look-alikes, each of which would run it: it doubled a search's cost
  /// and found no fix sooner (docs/localization.md).
  double global_search_below = 0.0;
  TrajectoryJoinOptions join{};       ///< when the loops of several keyframes fix the robot
  /// A fix the loops agree on is then checked as tracking would: the robot's keyframes of the
  /// join's window, placed by it, are matched to the map keyframes near them; at least this
  /// share of those with map keyframes near must fit (a look-alike street fits in places only).
  double fix_min_fitting_share = 0.7;
  /// Then the next keyframes are tracked on probation: the fix is declared (poses, state
  /// localized) once this many fit the map where it puts them; one that does not drops it.
  std::size_t confirm_keyframes = 2;
  double track_radius = 8.0;          ///< m; map keyframes this near the tracked pose are matched to a new keyframe
  std::size_t track_keyframes = 3;    ///< of those, the nearest this many (the best fit is taken)
  double min_track_fit = 0.35;        ///< a keyframe whose best fit (ScanAligner::fit) is below this does not fit the map
  double max_correction = 1.0;        ///< m; a match that moves the tracked pose farther does not fit either
  /// A fitting match whose innovation against the odometry's prediction (chi2 of the pose
  /// difference under both covariances, 3 dof) is above this is not taken: the keyframe is
  /// carried by odometry as off the map (0: off), unless the next keyframe's match, kept out
  /// too, agrees with it (within join/max_translation and join/max_rotation): then the
  /// prediction went astray, and that match is taken as it is. A poor fit pulled to another
  /// optimum in a fast turn is far outside both covariances, and alone. Off by default: at 30
  /// it mended freiburg-079's and intel's tracking but gave acapulco a wrong fix
  /// (docs/localization.md).
  double max_track_chi2 = 0.0;
  std::size_t lost_after_misfits = 2;  ///< consecutive keyframes that do not fit where the map has keyframes: lost
  double max_unmatched_travel = 15.0;  ///< m of path with no keyframe fitting the map (off the map): lost
  /// m of path after a pose hint (hint()) during which the search is narrowed to it; then the
  /// hint is dropped and the whole map searched again (a wrong hint never strands the robot).
  double hint_max_travel = 30.0;
  [[nodiscard]] std::string validate() const;
};

enum class LocalizationState { kLost, kLocalized };
/// "lost", "localized".
const char* localizationStateName(LocalizationState state);

/// What one scan did.
struct LocalizationStep {
  LocalizationState state = LocalizationState::kLost;  ///< after this scan
  bool has_pose = false;      ///< localized and the scan placed (pose valid)
  Pose2 pose;                 ///< the scan's pose in the map frame
  /// Of pose (x, y, theta in the map frame), to first order: the last map match's ICP
  /// covariance, and the odometry's since that keyframe.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// The scan's pose in the trajectory's own odometry frame (SlamFrontEnd's chain), whether
  /// localized or not: what a robot without wheels broadcasts as odom -> base_link.
  bool has_trajectory_pose = false;
  Pose2 trajectory_pose;
  bool keyframe = false;      ///< the scan made a keyframe of the trajectory
  bool fixed = false;         ///< this scan fixed the robot (the first fix, or after being lost)
  bool lost = false;          ///< this scan lost it
  double fit = -1.0;          ///< when a tracked keyframe: its best fit to the map (-1: none near); when fixed: the mean over the recent keyframes checked
  bool searched = false;        ///< a keyframe classified against the whole map (while lost)
  std::size_t candidates = 0;   ///< when searched: classifier candidates at or above the threshold, aligned
  std::size_t loops_to_map = 0;  ///< when searched: of those, shape-validated (look-alikes included)
  /// When searched: every candidate aligned, accepted or not, with what the aligner and shape
  /// validation said (from: the map keyframe; pose: this keyframe in its frame).
  std::vector<LoopClosure> search_results;
  TrajectoryJoinResult join;  ///< when a keyframe searched while lost: whether it fixed the robot, or why not
  std::string why_lost;       ///< when lost: why
  std::string skip_reason;    ///< non-empty: the front end did not use the scan
  double seconds = 0.0;       ///< computation of this scan
};

struct LocalizerCounters {
  std::size_t scans = 0, keyframes = 0;
  std::size_t searched_keyframes = 0;  ///< keyframes classified against the whole map (while lost)
  std::size_t loops_to_map = 0;        ///< shape-validated loops those gave
  std::size_t fixes = 0;               ///< first fix and relocalisations
  std::size_t lost_events = 0;         ///< localized, then lost
  std::size_t relocalizations = 0;     ///< fixes after a lost event or a forced search
  std::size_t tracked_keyframes = 0, misfit_keyframes = 0, off_map_keyframes = 0;
  std::size_t disagreeing_keyframes = 0;  ///< fitting matches that max_track_chi2 kept out

  std::size_t fixes_refused = 0;       ///< fixes the loops agreed on that the recent keyframes did not fit (verifyFix) ...
  std::size_t fixes_dropped = 0;       ///< ... or that a keyframe on probation did not fit (confirm_keyframes)
  /// The robot's keyframes whose scans were let go, out of the join's window (only their
  /// features and poses stay: a long run's memory stays bounded).
  std::size_t scans_released = 0;
  double seconds_front_end = 0.0, seconds_search = 0.0, seconds_track = 0.0;
};

/// chi2 of measured - predicted (heading wrapped) under the sum of their covariances (0 when
/// that sum cannot be inverted or is not finite: nothing to judge by).
double innovationChi2(const Pose2& predicted, const Eigen::Matrix3d& predicted_covariance, const Pose2& measured,
                      const Eigen::Matrix3d& measured_covariance);

/// A pose predicted (with its covariance) and one measured (with its): the measured one
/// becomes their covariance-weighted mean (a Kalman update), and its covariance the mean's.
/// Unchanged when the prediction has no covariance to weigh.
void fuse(const Pose2& predicted, const Eigen::Matrix3d& predicted_covariance, Pose2* measured,
          Eigen::Matrix3d* measured_covariance);

/// The aligner's options for the map's candidates while lost: mapping's, with validation's N
/// and the global search's threshold localisation's own.
ScanAlignerOptions mapAlignerOptions(ScanAlignerOptions aligner, const LocalizerOptions& options);

class Localizer {
 public:
  /// Throws std::invalid_argument on bad options, a model the extractor cannot serve, or a map
  /// session that does not validate or is empty. Features stored in the session are used when
  /// they are this model's (else recomputed); every map scan is prepared for alignment here.
  Localizer(const ClassifierModel& model, const SlamOptions& slam, const SlamSession& map, const LocalizerOptions& options = {});

  /// Feeds one scan (base frame) with its wheel-odometry pose when there is one. Nothing of
  /// the input's poses is taken as a position in the map. Never throws on bad data.
  LocalizationStep addScan(const Scan& scan, const Pose2* wheel_odometry);
  /// Forgets the fix and searches the whole map again from the next keyframe.
  void relocalize(const std::string& why);
  /// Forgets the fix and searches again, near `pose` only (the robot's pose now, in the map):
  /// the map keyframes within `radius` m of where the robot's odometry carries that pose,
  /// nearest first, instead of the classifier's candidates over the whole map; the loops must
  /// still agree (TrajectoryJoin) and fit. A hint is never needed: it lapses after
  /// hint_max_travel m of path without a fix. False (and nothing changed) on a non-finite pose
  /// or a radius not > 0.
  bool hint(const Pose2& pose, double radius);
  /// Whether a pose hint narrows the search now.
  bool hinted() const { return hint_.active; }

  LocalizationState state() const { return state_.confirmed ? LocalizationState::kLocalized : LocalizationState::kLost; }
  /// The trajectory's own frame (SlamFrontEnd's odometry frame) in the map; valid when localized.
  const Pose2& mapFromTrajectory() const { return state_.map_from_trajectory; }
  /// The newest keyframe's fit to the map (-1 before any was tracked).
  double lastFit() const { return state_.last_fit; }
  const LocalizerCounters& counters() const { return counters_; }
  /// m; the robot's path since the start by its own odometry.
  double pathLength() const { return path_.length; }
  const std::vector<Pose2>& mapPoses() const { return map_poses_; }
  const LocalizerOptions& options() const { return options_; }

 private:
  /// A keyframe while lost: loops to the map, offered to the join.
  void search(std::size_t keyframe, const Pose2& trajectory_pose, LocalizationStep& step);
  /// A keyframe while localized: matched to the map near its tracked pose.
  void track(std::size_t keyframe, const Pose2& trajectory_pose, const Eigen::Matrix3d& motion_covariance,
             LocalizationStep& step);
  /// A keyframe that did not fit the map: the covariance of its map pose is the last fitted
  /// keyframe's carried by the odometry step (motion_covariance, from the keyframe before).
  void carryCovariance(const Pose2& trajectory_pose, const Eigen::Matrix3d& motion_covariance);
  /// The robot's keyframe `keyframe` placed at `predicted` in the map: ICP to each of the
  /// nearest track_keyframes map keyframes within track_radius, the best fit (-1: none near)
  /// and where it puts the keyframe (moves over max_correction do not count).
  double fitToMap(std::size_t keyframe, const Pose2& predicted, Pose2* placed, Eigen::Matrix3d* covariance = nullptr) const;
  /// Whether the recent keyframes placed by map_from_trajectory fit the map (fix_min_fitting_share);
  /// else why not.
  std::string verifyFix(const Pose2& map_from_trajectory, double* mean_fit) const;
  /// The context check of mapping (checkLoopContext) on the fix's newest loop: the map's
  /// keyframes around its map keyframe against the robot's around its own keyframe. A fix that
  /// fits about as well shifted along a corridor is refused. "" or why not.
  std::string checkFixContext(const JoinHypothesis& loop) const;
  void loseTrack(const std::string& why, LocalizationStep& step);
  /// The fix is declared: counted, and the step says so.
  void declareFix(LocalizationStep& step);

  LocalizerOptions options_;
  SlamFrontEnd front_;  ///< the robot's trajectory: keyframes and odometry in its own frame
  LoopDetector map_;    ///< the map's keyframes, classified and aligned against
  std::vector<Pose2> map_poses_;
  TrajectoryJoin join_;
  LocalizerCounters counters_;

  /// Where the robot stands: reset as one when it is lost.
  struct TrackState {
    bool tracking = false;        ///< a fix is tracked, declared or on probation (confirm_keyframes)
    bool confirmed = false;       ///< declared: poses are given
    std::size_t confirmations = 0;  ///< keyframes that fitted the map since the fix
    Pose2 map_from_trajectory;
    std::size_t misfits = 0;      ///< consecutive keyframes that did not fit
    double last_fit_path = 0.0;   ///< path at the last keyframe that fitted
    double last_fit = -1.0;
    Eigen::Matrix3d keyframe_covariance = Eigen::Matrix3d::Zero();  ///< of the newest keyframe's map pose
    Pose2 keyframe_trajectory_pose;  ///< that keyframe's pose in the trajectory frame
    /// The last match max_track_chi2 kept out, as the frame it implies, while no match was
    /// taken since: a next one agreeing with it says the prediction, not the map, went astray.
    bool has_disagreement = false;
    Pose2 disagreeing_map_from_trajectory;
  };
  TrackState state_;
  bool had_fix_ = false;  ///< a fix from now on is a relocalisation
  /// A pose hint narrowing the search (hint()); reset as one.
  struct Hint {
    bool active = false;
    Pose2 map_from_trajectory;  ///< the hinted pose over the robot's odometry pose then
    double radius = 0.0;        ///< m
    double path = 0.0;          ///< the path length when it was given
  };
  Hint hint_;
  /// The map keyframes near the hint's position for a keyframe at `trajectory_pose`, nearest first.
  std::vector<std::size_t> hintedCandidates(const Pose2& trajectory_pose) const;
  /// The robot's keyframes within the join's window of path, newest last (verifyFix).
  struct RecentKeyframe {
    std::size_t keyframe;
    Pose2 trajectory_pose;
    double path;
  };
  std::deque<RecentKeyframe> recent_;
  /// The trajectory's path length by its own odometry.
  struct Path {
    bool has_last = false;
    Pose2 last;
    double length = 0.0;
  };
  Path path_;
};

}  // namespace llc
