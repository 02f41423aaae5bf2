// Localisation against ground truth: the map's frame laid onto the truth's by its keyframes,
// then each localized pose compared with its scan's true pose.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// One scan as the localiser placed it, with its true pose (truth frame).
struct LocalizedScan {
  bool localized = false;  ///< has a pose in the map
  bool fixed = false;      ///< the scan whose keyframe fixed the robot (first fix or relocalisation)
  Pose2 pose;              ///< map frame, when localized
  Pose2 truth;
  /// The scan's reference pose is contradicted by its own scans (checkReferencePose against
  /// the drive's scans on either side): judged wrong there, the pose may be right.
  bool reference_contradicted = false;
};

/// The map's keyframes with their true poses, and the map's frame laid onto the truth's.
struct MapWithTruth {
  std::vector<Pose2> poses;  ///< the map's keyframes, map frame
  std::vector<Pose2> truth;  ///< the same keyframes' true poses
  Pose2 truth_from_map;      ///< e.g. alignedRmsError(poses, truth)
};

struct LocalizationScore {
  std::size_t localized = 0;    ///< scans with a pose, judged
  /// Localized scans not judged: their truth lies farther than judge_within from every map
  /// keyframe's (off the map, carried by odometry: the map has no place there to judge by).
  std::size_t beyond_map = 0;
  std::size_t fixes = 0;        ///< fixed scans
  /// Against the map: each localized pose against where the map puts its truth, i.e. its
  /// truth relative to the map keyframe truly nearest, carried by that keyframe's map pose. A
  /// map that bends (no loop closed it) moves its places; a robot should be placed where its map
  /// has the place, and is judged so.
  std::size_t wrong_fixes = 0;  ///< fixed scans off by more than wrong_translation or wrong_rotation
  std::size_t wrong_poses = 0;  ///< localized scans off by as much
  /// Of the wrong fixes and poses, those whose scan's reference pose is contradicted.
  std::size_t wrong_fixes_contradicted = 0, wrong_poses_contradicted = 0;
  double rms_m = 0.0;           ///< position RMS of the localized scans
  double max_m = 0.0;           ///< largest position error of a localized scan
  /// Against the truth itself, through truth_from_map (the map's own bending included).
  std::size_t wrong_fixes_global = 0, wrong_poses_global = 0;
  double rms_global_m = 0.0;
};

/// Where the map has the place of a scan whose true pose is `truth`: its truth relative to the
/// map keyframe truly nearest, carried by that keyframe's map pose (through truth_from_map
/// when the map has no keyframe).
Pose2 whereTheMapHasIt(const MapWithTruth& map, const Pose2& truth, double* nearest_m = nullptr);

/// One localized scan's error (scan.pose measured from where it should be).
struct ScanError {
  Pose2 against_map;    ///< from whereTheMapHasIt
  Pose2 against_truth;  ///< from its truth, through truth_from_map
  double nearest_map_keyframe_m = 0.0;  ///< its truth from the nearest map keyframe's (inf: no keyframe)
};
ScanError scanError(const LocalizedScan& scan, const MapWithTruth& map);

/// An error over wrong_translation (m) or wrong_rotation (rad); a non-finite one is wrong.
bool wrongPose(const Pose2& error, double wrong_translation, double wrong_rotation);

/// Scores `scans` against the map (and against the truth: the *_global figures). Scans whose
/// truth is farther than `judge_within` m from every map keyframe's are counted, not judged.
LocalizationScore scoreLocalization(const std::vector<LocalizedScan>& scans, const MapWithTruth& map,
                                    double wrong_translation = 1.0, double wrong_rotation = 0.1,
                                    double judge_within = std::numeric_limits<double>::infinity());

/// Scans from which a localiser can be asked to find itself: those whose true path, over its
/// first `travel` m, passes within `radius` of a mapped pose (`mapped`, truth frame) heading
/// within `max_heading` rad of it. A start elsewhere drives where nothing was mapped; with a
/// max_heading below pi, where nothing was mapped looking that way (a scanner of less than the
/// full circle, driving a mapped corridor the other way round, sees what the map never saw).
std::vector<bool> startsNearMap(const std::vector<Pose2>& truth, const std::vector<Pose2>& mapped, double travel = 10.0,
                                double radius = 1.0, double max_heading = M_PI);

}  // namespace llc
