// The context check of a loop (beyond the paper): two scans of a long corridor can fit best
// at a look-alike stretch a door or two away, and shape validation cannot tell. The scans
// the robot took around each of the two keyframes (their "context", placed by its odometry,
// which is accurate over a few metres) see farther along it. The new keyframe's context is
// aligned to the old one's from the loop's pose and again from that pose shifted along the
// alignment's weakest direction; when the context fits clearly better elsewhere, the loop is
// refused.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/icp.hpp"
#include "laser_loop_closure/core/geometry/point_cloud.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct ContextCheckOptions {
  bool enabled = true;  ///< false: loops are not checked against their context (the paper)
  double distance = 8.0;  ///< m of driven path on each side of a loop's keyframes whose keyframes form its context
  double spacing = 0.8;   ///< m of path at least between two context keyframes (fewer scans, the same ground)
  std::size_t min_scans = 3;  ///< a context of fewer keyframes (each side, the loop's own included): not checked
  /// m; the new context is aligned again from the loop's pose shifted along its weakest
  /// direction by ±this, ±2x, ±4x (search_restarts of each sign)
  double search_shift = 1.0;
  int search_restarts = 3;  ///< see search_shift
  double fit_distance = 0.1;  ///< m; a point of the new context this near a point of the old one fits
  /// Refused when the context fits at another pose (more than alternative_distance away) by at
  /// least this share of its points better than at the loop's pose; a negative value refuses
  /// also a loop whose pose does not fit better than any other by more than -this (a corridor
  /// whose doors repeat: one place fits about as well as the next).
  double max_alternative_gain = -0.03;
  double alternative_distance = 0.5;  ///< m
  std::size_t max_points = 2000;  ///< points of the new context whose fit is counted (evenly strided)
  double cell = 0.05;  ///< m; each context's points thinned to one per square cell of this side (scans overlap)
  bool parallel = true;  ///< half the restarts on a second thread (the same verdict, less wall time)
  [[nodiscard]] std::string validate() const;
};

/// One keyframe of a context: its points and its pose in the frame of the loop's keyframe it
/// surrounds.
struct ContextScan {
  const Points2* points = nullptr;
  Pose2 pose;
  /// Its points' unit normals in its own frame, one per point (a PreparedScan's ICP target has
  /// them), or nullptr: then the old context's normals are estimated from its merged points.
  const Points2* normals = nullptr;
};

struct ContextCheckResult {
  bool checked = false;   ///< false: a context had fewer than min_scans keyframes (accepted unchecked)
  bool accepted = true;
  double fit = 0.0;              ///< share of the new context's points that fit at the loop's pose (refined by ICP)
  /// The best share elsewhere (0 when no restart ended elsewhere, or when fit is within
  /// max_alternative_gain of 1 and so nothing was searched: no share can beat it by that much)
  double alternative_fit = 0.0;
  Pose2 alternative;             ///< where (new keyframe in the old one's frame)
  std::size_t old_scans = 0, new_scans = 0;
  std::string reject_reason;  ///< "context: ..." when refused
};

/// The points of a context in the frame its poses are given in, thinned to the first point in
/// each square cell of side `cell` (0: all).
/// With `normals`, also the normals of the points kept (turned into that frame), or an empty
/// list when a scan has none.
Points2 contextCloud(const std::vector<ContextScan>& context, double cell, Points2* normals = nullptr);

/// The share of `source` points (every k-th, at most max_points) that lie within fit_distance
/// of a point of `target` once moved by `pose`.
double contextFit(const Points2& source, const KdTree2& target, const Pose2& pose, const ContextCheckOptions& options);

/// Checks a loop whose pose puts the new keyframe at `loop_pose` in the old one's frame
/// (`loop_covariance`: its covariance, whose largest x-y axis is the direction searched).
/// old_context is in the old keyframe's frame, new_context in the new one's. ICP runs with
/// `icp`. Never throws on geometry: an empty or degenerate context is accepted unchecked.
ContextCheckResult checkLoopContext(const std::vector<ContextScan>& old_context, const std::vector<ContextScan>& new_context,
                                    const Pose2& loop_pose, const Eigen::Matrix3d& loop_covariance,
                                    const ContextCheckOptions& options, const IcpOptions& icp);

}  // namespace llc
