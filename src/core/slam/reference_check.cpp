#include "laser_loop_closure/core/slam/reference_check.hpp"

#include <cmath>

namespace llc {
namespace {

/// ICP of `at` onto each neighbour from the reference's relative pose; the strongest verdict.
ReferenceSide checkSide(const ScanAligner& aligner, const PreparedScan& at, const Pose2& truth_at,
                        const std::vector<ReferenceNeighbour>& neighbours, const ReferenceCheckOptions& options) {
  ReferenceSide side;
  for (const ReferenceNeighbour& neighbour : neighbours) {
    if (!neighbour.scan) continue;
    const Pose2 reference = between(neighbour.truth, truth_at);
    const IcpResult icp = aligner.refine(*neighbour.scan, at, reference);
    if (!icp.converged) continue;
    ReferenceSide found;
    found.turn = std::abs(between(reference, icp.pose).theta);
    found.fit_gain = aligner.fit(*neighbour.scan, at, icp.pose) - aligner.fit(*neighbour.scan, at, reference);
    found.contradicts = found.turn > options.min_turn && found.fit_gain >= options.min_fit_gain;
    if ((found.contradicts && (!side.contradicts || found.turn > side.turn)) || (!side.contradicts && found.turn > side.turn))
      side = found;
  }
  return side;
}

}  // namespace

ReferenceCheck checkReferencePose(const ScanAligner& aligner, const PreparedScan& at, const Pose2& truth_at,
                                  const std::vector<ReferenceNeighbour>& before,
                                  const std::vector<ReferenceNeighbour>& after, const ReferenceCheckOptions& options) {
  ReferenceCheck check;
  check.before = checkSide(aligner, at, truth_at, before, options);
  check.after = checkSide(aligner, at, truth_at, after, options);
  check.contradicted = check.before.contradicts && check.after.contradicts;
  return check;
}

ReferenceNeighbourIndices referenceNeighbourIndices(const std::vector<Pose2>& truth, std::size_t at, double spacing_m,
                                                    double spacing_rad, std::size_t count, double max_distance) {
  ReferenceNeighbourIndices out;
  if (at >= truth.size()) return out;
  auto walk = [&](long step, std::vector<std::size_t>& taken) {
    Pose2 last = truth[at];
    for (long k = long(at) + step; k >= 0 && std::size_t(k) < truth.size() && taken.size() < count; k += step) {
      const Pose2& p = truth[std::size_t(k)];
      if (!isFinite(p) || std::hypot(p.x - truth[at].x, p.y - truth[at].y) > max_distance) break;
      if (std::hypot(p.x - last.x, p.y - last.y) < spacing_m && std::abs(normalizeAngle(p.theta - last.theta)) < spacing_rad)
        continue;
      taken.push_back(std::size_t(k));
      last = p;
    }
  };
  walk(-1, out.before);
  walk(+1, out.after);
  return out;
}

}  // namespace llc
