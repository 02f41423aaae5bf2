#include "laser_loop_closure/core/alignment/scan_aligner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <future>
#include <stdexcept>

namespace llc {

std::string ScanAlignerOptions::validate() const {
  if (!(max_range > 0.0)) return "max_range must be > 0";
  if (!(selection_distance > 0.0)) return "selection_distance must be > 0";
  if (!(reverse_below >= 0.0 && reverse_below <= 1.0)) return "reverse_below must be in [0, 1]";
  if (!(global_search_below >= 0.0 && global_search_below <= 1.0)) return "global_search_below must be in [0, 1]";
  if (!(min_relative_overlap >= 0.0 && min_relative_overlap <= 1.0)) return "min_relative_overlap must be in [0, 1]";
  if (!(weak_direction_shift > 0.0) || !std::isfinite(weak_direction_shift)) return "weak_direction_shift must be finite and > 0";
  if (weak_direction_restarts < 0 || weak_direction_restarts > 8) return "weak_direction_restarts must be in [0, 8]";
  if (!(weak_direction_above >= 0.0 && weak_direction_above <= 1.0)) return "weak_direction_above must be in [0, 1]";
  std::string error = crf.validate();
  if (!error.empty()) return "crf: " + error;
  error = global.validate();
  if (!error.empty()) return "global: " + error;
  error = icp.validate();
  if (!error.empty()) return "icp: " + error;
  error = validation.validate();
  if (!error.empty()) return "validation: " + error;
  return "";
}

MatchTarget::MatchTarget(Points2 points_in, const IcpOptions& icp, const FieldOfView& view_in)
    : points(std::move(points_in)), view(view_in), icp_target(points, icp) {}

PreparedScan::PreparedScan(Points2 points_in, const ScanAlignerOptions& options, const FieldOfView& view_in)
    : MatchTarget(std::move(points_in), options.icp, view_in), crf(describeForCrf(points, options.crf)),
      global(describeForGlobalSearch(points, icp_target.normals, options.global)) {}

ScanAligner::ScanAligner(const ScanAlignerOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("alignment options: " + error);
}

std::shared_ptr<const PreparedScan> ScanAligner::prepare(const Scan& scan) const {
  auto prepared = std::make_shared<PreparedScan>(scanPoints(scan, options_.max_range), options_,
                                                 fieldOfView(scan, options_.max_range));
  if (options_.validation.max_seen_through_share < 1.0) prepared->free_space = freeSpace(scan, options_.max_range);
  return prepared;
}

namespace {

/// ICP from each start, in order: every converged result with its fit, and the reason of the
/// first start that did not converge.
struct StartResults {
  std::vector<IcpResult> converged;
  std::vector<AlignmentFit> fits;
  IcpResult first_failure;
  bool any_failure = false;
};

/// The share of points within selection_distance (tighter than validation's d, so that a
/// result shifted along a corridor loses to the right one), both ways, among the points the
/// other scanner could have seen (as validation counts them). Counting every point instead
/// favoured a result that puts the two scanners at one spot: from there both see the same
/// stretch of a corridor, while at the truth each sees a little the other cannot.
AlignmentFit twoWayFit(const PreparedScan& a, const PreparedScan& b, const Pose2& pose, const ScanAlignerOptions& options) {
  ShapeValidationOptions tight = options.validation;
  tight.max_distance = options.selection_distance;
  const ShapeValidationResult forward = validateShape(b.points, a.icp_target.tree, pose, tight, &a.view);
  const ShapeValidationResult backward = validateShape(a.points, b.icp_target.tree, inverse(pose), tight, &b.view);
  return {0.5 * (forward.inlier_share + backward.inlier_share), forward.points + backward.points};
}

IcpResult refineFrom(const PreparedScan& a, const PreparedScan& b, const Pose2& start, const ScanAlignerOptions& options) {
  return alignIcp(b.points, a.icp_target, start, options.icp, &b.icp_target.normals, &a.view);
}

StartResults tryStarts(const PreparedScan& a, const PreparedScan& b, const std::vector<Pose2>& starts,
                       const ScanAlignerOptions& options) {
  StartResults out;
  for (const Pose2& start_pose : starts) {
    IcpResult icp = refineFrom(a, b, start_pose, options);
    if (!icp.converged) {
      if (!out.any_failure) out.first_failure = std::move(icp), out.any_failure = true;
      continue;
    }
    out.fits.push_back(twoWayFit(a, b, icp.pose, options));
    out.converged.push_back(std::move(icp));
  }
  return out;
}

/// CRF-match of a's contour as the chain (b to a the other way round), and ICP from its starts.
struct ReverseMatch {
  CrfMatchResult crf;
  StartResults starts;
};

ReverseMatch matchReverse(const PreparedScan& a, const PreparedScan& b, const ScanAlignerOptions& options) {
  ReverseMatch reverse;
  reverse.crf = matchCrf(a.crf, b.crf, options.crf);
  if (!reverse.crf.ok) return reverse;
  std::vector<Pose2> starts = {inverse(reverse.crf.pose)};
  for (const Pose2& p : reverse.crf.alternatives) starts.push_back(inverse(p));
  reverse.starts = tryStarts(a, b, starts, options);
  return reverse;
}

}  // namespace

std::size_t pickAlignment(const std::vector<AlignmentFit>& fits, double min_relative_overlap) {
  // A pose that leaves few points in the other's view can fit those few well (a 180-degree
  // scan turned round, seeing only the other's side walls): it competes only with its like.
  std::size_t largest = 0;
  for (const AlignmentFit& f : fits) largest = std::max(largest, f.overlap);
  std::size_t winner = 0;
  double best = -1.0;
  for (std::size_t k = 0; k < fits.size(); ++k)
    if (double(fits[k].overlap) >= min_relative_overlap * double(largest) && fits[k].share > best)
      best = fits[k].share, winner = k;
  return winner;
}

std::vector<Pose2> weakDirectionStarts(const Pose2& pose, const Eigen::Matrix3d& covariance, double shift, int count) {
  const double xx = covariance(0, 0), xy = covariance(0, 1), yy = covariance(1, 1);
  const double angle = 0.5 * std::atan2(2.0 * xy, xx - yy);  // of the larger eigenvalue's axis
  std::vector<Pose2> starts;
  for (int k = 0; k < count; ++k)
    for (const double sign : {-1.0, 1.0}) {
      const double d = sign * shift * double(1 << k);
      starts.push_back({pose.x + d * std::cos(angle), pose.y + d * std::sin(angle), pose.theta});
    }
  return starts;
}

double ScanAligner::fit(const PreparedScan& a, const PreparedScan& b, const Pose2& pose) const {
  return twoWayFit(a, b, pose, options_).share;
}

const char* alignmentRefusalName(AlignmentRefusal refusal) {
  switch (refusal) {
    case AlignmentRefusal::kNone: return "none";
    case AlignmentRefusal::kNoStart: return "no_start";
    case AlignmentRefusal::kIcp: return "icp";
    case AlignmentRefusal::kValidation: return "validation";
  }
  return "none";
}

IcpResult ScanAligner::refine(const PreparedScan& a, const PreparedScan& b, const Pose2& start) const {
  return refineFrom(a, b, start, options_);
}

ScanAlignmentResult ScanAligner::align(const PreparedScan& a, const PreparedScan& b, bool second_thread) const {
  const auto start = std::chrono::steady_clock::now();
  const bool parallel = second_thread && options_.parallel;
  ScanAlignmentResult result;
  auto finish = [&](AlignmentRefusal refusal, std::string reason) {
    result.refusal = refusal;
    result.reject_reason = std::move(reason);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  // The reverse match is needed only when the forward one fits poorly, but that is the common
  // case (candidates are mostly other places): with parallel, it runs beside the forward one
  // and is dropped when not needed, so the result is the same as one after the other.
  std::future<ReverseMatch> reverse_ahead;
  if (parallel) reverse_ahead = std::async(std::launch::async, matchReverse, std::cref(a), std::cref(b), std::cref(options_));

  std::vector<IcpResult> converged;
  std::vector<AlignmentFit> fits;
  double best_share = -1.0;  // of every converged result so far: do more starts pay?
  auto take = [&](StartResults&& starts) {
    if (starts.any_failure && converged.empty() && result.icp.reject_reason.empty())
      result.icp = std::move(starts.first_failure);
    for (std::size_t k = 0; k < starts.converged.size(); ++k) {
      result.icp_poses.push_back(starts.converged[k].pose);
      result.icp_shares.push_back(starts.fits[k].share);
      best_share = std::max(best_share, starts.fits[k].share);
      converged.push_back(std::move(starts.converged[k]));
      fits.push_back(starts.fits[k]);
    }
  };
  bool crf_found_none = false;
  // ICP from the CRF's transform and from its runners-up.
  result.crf = matchCrf(b.crf, a.crf, options_.crf);
  if (result.crf.ok) {
    std::vector<Pose2> starts = {result.crf.pose};
    starts.insert(starts.end(), result.crf.alternatives.begin(), result.crf.alternatives.end());
    take(tryStarts(a, b, starts, options_));
  }
  // A poor best fit: CRF-match the other way round (a's contour as the chain) for more starts.
  if (best_share < options_.reverse_below) {
    ReverseMatch reverse = parallel ? reverse_ahead.get() : matchReverse(a, b, options_);
    if (reverse.crf.ok) take(std::move(reverse.starts));
    crf_found_none = !result.crf.ok && !reverse.crf.ok;
  }
  // Nothing, or still poor: starts that do not depend on matching descriptors along contours.
  if (converged.empty() || best_share < options_.global_search_below) {
    result.global = searchGlobally(a.global, b.global, options_.global);
    take(tryStarts(a, b, result.global.poses, options_));
  }
  if (converged.empty() && crf_found_none && result.global.poses.empty())
    return finish(AlignmentRefusal::kNoStart, "crf: " + result.crf.reject_reason + "; global search: " + result.global.reject_reason);
  if (converged.empty()) return finish(AlignmentRefusal::kIcp, "icp: " + result.icp.reject_reason);
  std::size_t winner = pickAlignment(fits, options_.min_relative_overlap);
  // The local optima of a corridor line up along it: restart from the winner shifted that way
  // (unless it fits so poorly that the pair is most likely two places, as most candidates are).
  if (options_.weak_direction_restarts > 0 && fits[winner].share >= options_.weak_direction_above) {
    take(tryStarts(a, b, weakDirectionStarts(converged[winner].pose, converged[winner].covariance,
                                             options_.weak_direction_shift, options_.weak_direction_restarts), options_));
    winner = pickAlignment(fits, options_.min_relative_overlap);
  }
  result.chosen = winner;  // converged and icp_poses run in step
  result.icp = std::move(converged[winner]);
  result.pose = result.icp.pose;
  result.covariance = result.icp.covariance;
  result.validation = validateShape(b.points, a.icp_target.tree, result.pose, options_.validation, &a.view);
  if (!result.validation.accepted) return finish(AlignmentRefusal::kValidation, "validation: " + result.validation.reject_reason);
  const ShapeValidationOptions& validation = options_.validation;
  // The tests beyond the paper refuse the same way: `format` shows the measured value and its limit.
  auto refuse = [&](const char* format, double value, double limit) {
    result.validation.accepted = false;
    char text[96];
    std::snprintf(text, sizeof text, format, value, limit);
    result.validation.reject_reason = text;
    return finish(AlignmentRefusal::kValidation, std::string("validation: ") + text);
  };
  if (validation.max_position_std > 0.0) {
    // The largest eigenvalue of the symmetric 2x2 x-y block, in closed form.
    const double xx = result.covariance(0, 0), xy = result.covariance(0, 1), yy = result.covariance(1, 1);
    const double largest = 0.5 * (xx + yy) + std::sqrt(0.25 * (xx - yy) * (xx - yy) + xy * xy);
    result.validation.position_std = std::sqrt(std::max(0.0, largest));
    if (!(result.validation.position_std <= validation.max_position_std))
      return refuse("position std %.4f m above %.4f m", result.validation.position_std, validation.max_position_std);
  }
  if (validation.max_seen_through_share < 1.0 && !a.free_space.empty() && !b.free_space.empty()) {
    result.validation.seen_through_share =
        std::max(seenThroughShare(b.points, result.pose, a.free_space, validation.free_space_margin),
                 seenThroughShare(a.points, inverse(result.pose), b.free_space, validation.free_space_margin));
    if (result.validation.seen_through_share > validation.max_seen_through_share)
      return refuse("seen-through share %.3f above %.3f", result.validation.seen_through_share, validation.max_seen_through_share);
  }
  result.accepted = true;
  return finish(AlignmentRefusal::kNone, "");
}

}  // namespace llc
