#include "laser_loop_closure/core/scan_aligner.hpp"

#include <chrono>
#include <stdexcept>

namespace llc {

std::string ScanAlignerOptions::validate() const {
  if (!(max_range > 0.0)) return "max_range must be > 0";
  if (!(selection_distance > 0.0)) return "selection_distance must be > 0";
  if (!(reverse_below >= 0.0 && reverse_below <= 1.0)) return "reverse_below must be in [0, 1]";
  std::string error = crf.validate();
  if (!error.empty()) return "crf: " + error;
  error = icp.validate();
  if (!error.empty()) return "icp: " + error;
  error = validation.validate();
  if (!error.empty()) return "validation: " + error;
  return "";
}

PreparedScan::PreparedScan(Points2 points_in, const ScanAlignerOptions& options, const FieldOfView& view_in)
    : points(std::move(points_in)), view(view_in), crf(describeForCrf(points, options.crf)), icp_target(points, options.icp) {}

ScanAligner::ScanAligner(const ScanAlignerOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("alignment options: " + error);
}

std::shared_ptr<const PreparedScan> ScanAligner::prepare(const Scan& scan) const {
  return std::make_shared<const PreparedScan>(scanPoints(scan, options_.max_range), options_,
                                              fieldOfView(scan, options_.max_range));
}

ScanAlignmentResult ScanAligner::align(const PreparedScan& a, const PreparedScan& b) const {
  const auto start = std::chrono::steady_clock::now();
  ScanAlignmentResult result;
  auto finish = [&](std::string reason) {
    result.reject_reason = std::move(reason);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  result.crf = matchCrf(b.crf, a.crf, options_.crf);
  // ICP from the CRF's transform and from its runners-up; the result with the largest share of
  // points within selection_distance of the other scan wins (tighter than validation's d, so
  // that a result shifted along a corridor loses to the right one).
  bool any = false;
  double best_fit = -1.0;
  ShapeValidationOptions tight = options_.validation;
  tight.max_distance = options_.selection_distance;
  auto tryStarts = [&](const std::vector<Pose2>& starts) {
    for (const Pose2& start_pose : starts) {
      IcpResult icp = alignIcp(b.points, a.icp_target, start_pose, options_.icp, &b.icp_target.normals);
      if (!icp.converged) {
        if (!any && result.icp.reject_reason.empty()) result.icp = icp;
        continue;
      }
      // Both ways: a result shifted along a corridor leaves the ends of the other scan unmatched.
      const double fit = 0.5 * (validateShape(b.points, a.icp_target.tree, icp.pose, tight).inlier_share +
                                validateShape(a.points, b.icp_target.tree, inverse(icp.pose), tight).inlier_share);
      result.icp_poses.push_back(icp.pose);
      result.icp_shares.push_back(fit);
      if (!any || fit > best_fit) {
        result.icp = std::move(icp);
        best_fit = fit;
        any = true;
      }
    }
  };
  std::vector<Pose2> starts;
  if (result.crf.ok) {
    starts = {result.crf.pose};
    starts.insert(starts.end(), result.crf.alternatives.begin(), result.crf.alternatives.end());
    tryStarts(starts);
  }
  // A poor best fit: CRF-match the other way round (a's contour as the chain) for more starts.
  if (best_fit < options_.reverse_below) {
    const CrfMatchResult reverse = matchCrf(a.crf, b.crf, options_.crf);
    if (reverse.ok) {
      starts = {inverse(reverse.pose)};
      for (const Pose2& p : reverse.alternatives) starts.push_back(inverse(p));
      tryStarts(starts);
    }
    if (!result.crf.ok && !reverse.ok) return finish("crf: " + result.crf.reject_reason);
  }
  if (!any) return finish("icp: " + result.icp.reject_reason);
  result.pose = result.icp.pose;
  result.covariance = result.icp.covariance;
  result.validation = validateShape(b.points, a.icp_target.tree, result.pose, options_.validation, &a.view);
  if (!result.validation.accepted) return finish("validation: " + result.validation.reject_reason);
  result.accepted = true;
  return finish("");
}

}  // namespace llc
