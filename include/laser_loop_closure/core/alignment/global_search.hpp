// A prior-free search for the pose of one scan in another's frame that does not rely on
// matching point descriptors: the rotation from the correlation of the two scans' histograms
// of surface orientation, then, for each likely rotation, the translation by Hough voting of
// point pairs whose surfaces face the same way. The aligner uses it as a fallback when
// CRF-match gives no start from which ICP fits well (e.g. few distinctive places along a
// contour); its poses are starts for ICP, not results.
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"

namespace llc {

struct GlobalSearchOptions {
  double sample_spacing = 0.15;    ///< m; points thinned to one per this distance along the scan
  double angle_bin = 0.035;        ///< rad (2 deg); bin of the orientation histograms
  int rotations = 8;               ///< best peaks of the orientation correlation tried as rotations
  double cell = 0.2;               ///< m; cell of the translation vote grid
  double max_translation = 10.0;   ///< m; translations searched in [-this, this] on each axis
  double max_normal_angle = 0.35;  ///< rad; point pairs whose surfaces (after rotation) differ more do not vote
  int hypotheses = 6;              ///< poses returned, most votes first
  double distinct_distance = 0.5;  ///< m; a returned pose is this far from better ones (same rotation) ...
  [[nodiscard]] std::string validate() const;
};

/// What the search needs of one scan, computed once: its thinned points and the direction of
/// the surface normal at each, turned towards the scanner (so a wall's two sides differ).
struct GlobalSearchScan {
  Points2 points;
  std::vector<double> normal_angles;  ///< rad in [-pi, pi], one per point
};
/// From a scan's points in beam order and their unit normals (zero: no surface; such points
/// are left out).
GlobalSearchScan describeForGlobalSearch(const Points2& points, const Points2& normals, const GlobalSearchOptions& options);

struct GlobalSearchResult {
  std::vector<Pose2> poses;   ///< scan b in the frame of scan a, most votes first
  std::vector<double> votes;  ///< per pose: the pairs that voted for its cell and the 8 around it
  double seconds = 0.0;
  std::string reject_reason;  ///< why there is no pose (empty when there is one)
};

/// Poses of b in a's frame that many surface pairs agree on (no initial guess).
GlobalSearchResult searchGlobally(const GlobalSearchScan& a, const GlobalSearchScan& b, const GlobalSearchOptions& options);

}  // namespace llc
