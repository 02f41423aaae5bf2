#include "laser_loop_closure/core/alignment/context_check.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <future>
#include <system_error>
#include <unordered_set>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"

namespace llc {

std::string ContextCheckOptions::validate() const {
  if (!(distance > 0.0) || !std::isfinite(distance)) return "distance must be > 0 m";
  if (!(spacing >= 0.0) || !std::isfinite(spacing)) return "spacing must be >= 0 m";
  if (min_scans < 1) return "min_scans must be >= 1";
  if (!(search_shift > 0.0) || !std::isfinite(search_shift)) return "search_shift must be > 0 m";
  if (search_restarts < 1 || search_restarts > 10) return "search_restarts must be in [1, 10]";
  if (!(fit_distance > 0.0) || !std::isfinite(fit_distance)) return "fit_distance must be > 0 m";
  if (!(max_alternative_gain >= -1.0 && max_alternative_gain <= 1.0)) return "max_alternative_gain must be in [-1, 1]";
  if (!(alternative_distance > 0.0) || !std::isfinite(alternative_distance)) return "alternative_distance must be > 0 m";
  if (max_points < 10) return "max_points must be >= 10";
  if (!(cell >= 0.0) || !std::isfinite(cell)) return "cell must be >= 0 m";
  return "";
}

Points2 contextCloud(const std::vector<ContextScan>& context, double cell, Points2* normals) {
  Points2 cloud;
  std::unordered_set<std::uint64_t> taken;
  bool all_normals = normals != nullptr;
  if (normals) normals->clear();
  for (const ContextScan& scan : context) {
    if (!scan.points) continue;
    const RigidMotion2 motion(scan.pose);
    const bool has_normals = scan.normals && scan.normals->size() == scan.points->size();
    all_normals = all_normals && has_normals;
    const Eigen::Rotation2Dd turn(scan.pose.theta);
    for (std::size_t i = 0; i < scan.points->size(); ++i) {
      const Point2 moved = motion((*scan.points)[i]);
      if (!std::isfinite(moved.x()) || !std::isfinite(moved.y())) continue;
      if (cell > 0.0) {
        // Cells of a 2^32 x 2^32 grid (wraps beyond 2e8 m at 5 cm: contexts span metres).
        const auto ix = std::uint32_t(std::int64_t(std::floor(moved.x() / cell)));
        const auto iy = std::uint32_t(std::int64_t(std::floor(moved.y() / cell)));
        if (!taken.insert((std::uint64_t(ix) << 32) | iy).second) continue;
      }
      cloud.push_back(moved);
      if (all_normals) normals->push_back(turn * (*scan.normals)[i]);
    }
  }
  if (normals && !all_normals) normals->clear();
  return cloud;
}

double contextFit(const Points2& source, const KdTree2& target, const Pose2& pose, const ContextCheckOptions& options) {
  if (source.empty() || target.size() == 0) return 0.0;
  const std::size_t stride = (source.size() + options.max_points - 1) / options.max_points;
  const double limit = options.fit_distance * options.fit_distance;
  const RigidMotion2 motion(pose);
  std::size_t counted = 0, fitting = 0;
  for (std::size_t i = 0; i < source.size(); i += stride) {
    std::size_t index = 0;
    double squared = 0.0;
    ++counted;
    fitting += target.nearest(motion(source[i]), &index, &squared, limit);
  }
  return double(fitting) / double(counted);
}

ContextCheckResult checkLoopContext(const std::vector<ContextScan>& old_context, const std::vector<ContextScan>& new_context,
                                    const Pose2& loop_pose, const Eigen::Matrix3d& loop_covariance,
                                    const ContextCheckOptions& options, const IcpOptions& icp) {
  ContextCheckResult result;
  result.old_scans = old_context.size();
  result.new_scans = new_context.size();
  if (old_context.size() < options.min_scans || new_context.size() < options.min_scans) return result;
  const Points2 source = contextCloud(new_context, options.cell);
  Points2 target_normals;
  Points2 target_points = contextCloud(old_context, options.cell, &target_normals);
  if (source.size() < std::size_t(icp.min_correspondences) || target_points.size() < std::size_t(icp.min_correspondences))
    return result;
  // The scans' own normals where they came with them: estimating them again on the merged
  // points costs most of the check.
  const IcpTarget target = target_normals.size() == target_points.size()
                               ? IcpTarget(std::move(target_points), std::move(target_normals))
                               : IcpTarget(std::move(target_points), icp);
  // ICP from a start; where it does not converge (a degenerate context), the start itself.
  auto refine = [&](const Pose2& start, double* fit) {
    const IcpResult refined = alignIcp(source, target, start, icp);
    const Pose2 pose = refined.converged && isFinite(refined.pose) ? refined.pose : start;
    *fit = contextFit(source, target.tree, pose, options);
    return pose;
  };
  result.checked = true;
  const Pose2 at_loop = refine(loop_pose, &result.fit);
  // No share exceeds 1: a context that fits this well cannot fit better enough elsewhere.
  if (result.fit + options.max_alternative_gain > 1.0) return result;
  const std::vector<Pose2> starts =
      weakDirectionStarts(at_loop, loop_covariance, options.search_shift, options.search_restarts);
  std::vector<Pose2> ends(starts.size());
  std::vector<double> fits(starts.size(), 0.0);
  auto search = [&](std::size_t first, std::size_t step) {
    for (std::size_t i = first; i < starts.size(); i += step) ends[i] = refine(starts[i], &fits[i]);
  };
  bool searched = false;
  if (options.parallel && starts.size() > 1) {
    try {  // every other start on a second thread: each ICP is independent, the verdict the same
      std::future<void> other = std::async(std::launch::async, search, 1, 2);
      search(0, 2);
      other.get();
      searched = true;
    } catch (const std::system_error&) {  // no thread to be had: all on this one
    }
  }
  if (!searched) search(0, 1);
  for (std::size_t i = 0; i < starts.size(); ++i)  // in the starts' order, as one thread would
    if (std::hypot(ends[i].x - at_loop.x, ends[i].y - at_loop.y) > options.alternative_distance &&
        fits[i] > result.alternative_fit) {
      result.alternative_fit = fits[i];
      result.alternative = ends[i];
    }
  if (result.alternative_fit >= result.fit + options.max_alternative_gain) {
    result.accepted = false;
    char text[160];
    std::snprintf(text, sizeof text, "context: fits %.3f at (%.2f, %.2f) m against %.3f at the loop's pose (gain above %.3f)",
                  result.alternative_fit, result.alternative.x, result.alternative.y, result.fit, options.max_alternative_gain);
    result.reject_reason = text;
  }
  return result;
}

}  // namespace llc
