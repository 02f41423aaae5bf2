// The vocabulary the SLAM stages share: what a keyframe, an odometry step, a loop closure, a
// loop as the back end met it, and a session are. The front end makes them, the back end and
// the session files keep them, the ROS adapter converts them: each depends on this header,
// not on the others' classes.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"

namespace llc {

/// A keyframe as the map and the session keep it.
struct Keyframe {
  std::size_t scan_index = 0;  ///< the caller's index of the scan it was made from
  double stamp = 0.0;          ///< s
  Scan scan;                   ///< in the base frame
  Pose2 wheel_odometry;        ///< in the odometry frame (when has_wheel_odometry)
  bool has_wheel_odometry = false;
};

/// The one place a keyframe is assembled (llc slam's pipeline and the loop_closure nodelet):
/// scan_index is the caller's count of scans, wheel_odometry null when there is none.
inline Keyframe makeKeyframe(Scan scan, std::size_t scan_index, const Pose2* wheel_odometry) {
  Keyframe keyframe;
  keyframe.scan_index = scan_index;
  keyframe.stamp = scan.stamp;
  keyframe.scan = std::move(scan);
  keyframe.has_wheel_odometry = wheel_odometry != nullptr;
  if (wheel_odometry) keyframe.wheel_odometry = *wheel_odometry;
  return keyframe;
}

/// The motion from one keyframe to the next and how it was measured.
/// Why a keyframe step was not measured by scan matching (the guess was used instead), or
/// that it starts a new chain: a name reports and diagnostics count by.
enum class OdometryRefusal {
  kNone,              ///< matched by ICP, or scan matching is off
  kIcp,               ///< ICP did not converge ("icp: ...")
  kTooFarFromWheels,  ///< ICP moved beyond max_correction_* from the wheels' guess
  kLowOverlap,        ///< the matched scans overlap less than min_overlap_share
  kNewChain,          ///< a new chain (after a restored session or a time jump back): no motion
};
constexpr std::size_t kOdometryRefusalKinds = 5;
/// "none", "icp", "too_far_from_wheels", "low_overlap", "new_chain".
const char* odometryRefusalName(OdometryRefusal refusal);

/// Why the front end skipped a scan.
enum class ScanRefusal {
  kNone,
  kStampNotFinite,
  kRangesAndBearingsDiffer,  ///< the two arrays differ in count
  kWheelOdometryNotFinite,
  kTimeWentBackwards,        ///< older than the newest keyframe, by less than restart_after_jump_back
};
constexpr std::size_t kScanRefusalKinds = 5;
/// "none", "stamp_not_finite", "ranges_bearings_differ", "wheel_odometry_not_finite",
/// "time_went_backwards".
const char* scanRefusalName(ScanRefusal refusal);

struct OdometryStep {
  Pose2 motion;                    ///< the new keyframe in the frame of the previous one
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of motion's x, y, theta
  bool matched = false;            ///< ICP was used; else the guess (wheel odometry)
  double overlap_share = 0.0;      ///< after ICP
  double seconds = 0.0;
  std::string reject_reason;       ///< why ICP was not used (empty when matched or not tried)
  OdometryRefusal refusal = OdometryRefusal::kNone;  ///< the same as a name
  /// Squared Mahalanobis distance of ICP's result from the wheel guess under the modelled wheel
  /// covariance (negative when there was no such comparison: no wheels, or ICP failed).
  double wheel_disagreement = -1.0;
  bool disputed = false;  ///< matched, but beyond max_wheel_disagreement: the covariance spans both
  /// matched from the correlative search's start, over the wheels (correlative_recovery)
  bool recovered = false;
  bool realigned = false;  ///< ICP's result doubted (realign_below_overlap): the no-guess alignment's pose
  bool tracked = false;  ///< ICP seeded by the tracked guess (match_every_scan), not the wheels'
  /// ICP's own covariance of motion (ScanOdometry::stepCovarianceOf) when matched by ICP; zero
  /// otherwise. Part of `covariance` only without wheels (icp_covariance_scale).
  Eigen::Matrix3d icp_covariance = Eigen::Matrix3d::Zero();
  /// m; how far the scan could shift along ICP's weakest direction and fit as well
  /// (ScanOdometry::widenAlongAmbiguity; 0 where not looked at).
  double ambiguous_shift = 0.0;
  bool widened_along_ambiguity = false;  ///< its covariance was widened to ambiguous_shift there
};

/// A keyframe the map puts near a new one (a NearbyKeyframes answer).
struct NearbyKeyframe {
  std::size_t keyframe = 0;
  bool has_pose = false;  ///< pose known (a source that gives none: the pair is searched with no guess)
  Pose2 pose;             ///< the new keyframe in this one's frame, where the map puts it
};

/// Why a candidate loop was not applied, by the stage that refused it: a name that reports,
/// diagnostics and scripts count by (the reject_reason text beside it gives the details; no decision reads that text).
enum class LoopRefusal {
  kNone,               ///< applied (or not refused)
  kPlaceGate,          ///< the back end's state puts the two keyframes too far apart ("place gate: ...")
  kCrfMatch,           ///< no start for ICP: CRF-match and the global search found none ("crf: ...")
  kIcp,                ///< ICP did not converge from any start ("icp: ...")
  kValidation,         ///< aligned, but shape validation refused it ("validation: ...")
  kContext,            ///< shape-validated, but the keyframes around it fit better elsewhere ("context: ...")
  kBackEndGate,        ///< the back end's chi-square gate ("backend: innovation chi2 ...")
  kBackEndUnsolvable,  ///< the filter could not be solved with it, taken back ("backend: the system could not be solved ...")
  kBackEndMalformed,   ///< unknown keyframes, a non-finite pose or an unusable covariance ("backend: ...")
  kOther,              ///< none of the above (a code a message carries that this build does not know)
};
constexpr std::size_t kLoopRefusalKinds = 10;
/// "none", "place_gate", "crf_match", "icp", "validation", "context", "back_end_gate",
/// "back_end_unsolvable", "back_end_malformed", "other".
const char* loopRefusalName(LoopRefusal refusal);

/// A stage's verdict on a loop candidate: decisions read `refusal`, people read `reason`
/// (rewording a reason changes nothing but the text).
struct [[nodiscard]] LoopVerdict {
  LoopRefusal refusal = LoopRefusal::kNone;
  std::string reason;  ///< empty when not refused
  bool refused() const { return refusal != LoopRefusal::kNone; }
};

/// One aligned candidate pair and its verdict.
struct LoopClosure {
  std::size_t from = 0, to = 0;  ///< keyframes: the stored one and the new one
  double score = 0.0;            ///< classifier, normalised
  Pose2 pose;                    ///< keyframe `to` in the frame of keyframe `from`
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of pose's x, y, theta
  double inlier_share = 0.0;     ///< shape validation
  bool accepted = false;         ///< aligned and shape-validated
  LoopRefusal refusal = LoopRefusal::kNone;  ///< the stage that refused it: what decisions and counters read
  std::string reject_reason;     ///< the same for people, with the measured values (empty when accepted)
  double seconds = 0.0;
};


/// One loop as the back end met it.
struct LoopRecord {
  LoopClosure loop;
  bool applied = false;          ///< accepted by alignment and by the back end's gate
  double innovation_chi2 = 0.0;  ///< when it reached the back end
  bool by_consensus = false;     ///< refused by the gate, applied later with loops that agree (LoopConsensus; kept in session files from version 2)
  LoopRefusal refusal = LoopRefusal::kNone;  ///< the aligner's or the back end's; kNone when applied
  std::string reject_reason;     ///< the same for people; empty when applied
};

/// Everything a mapping run holds, as a session file keeps it (session_io.hpp reads and writes it).
struct SlamSession {
  std::vector<Keyframe> keyframes;
  std::vector<std::vector<double>> features;  ///< one vector per keyframe (the front end's)
  std::vector<Pose2> poses;                   ///< optimised, one per keyframe
  std::vector<PoseEdge> constraints;          ///< the ESDF's, in the order applied
  std::vector<LoopRecord> loops;              ///< every loop that reached the back end
  /// Per keyframe, the robot that made it (several robots' map, MultiRobotSlam: 0 is the map
  /// frame's robot); empty: every keyframe robot 0's (one robot, or a file before version 4).
  std::vector<std::uint32_t> robots;
  /// Empty, or why the pieces do not fit together (counts, indices, non-finite values).
  [[nodiscard]] std::string validate() const;
};

}  // namespace llc
