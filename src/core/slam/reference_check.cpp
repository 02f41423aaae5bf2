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

}  // namespace llc
