// One rule for every choice among a step's seeds: the wheels', the tracked scan's, the motion
// model's, a correlative search's and a realignment's poses are scored by one measure (the mean
// likelihood of the scan's points in the step's target's field: correlativeScore) and one
// margin decides.
#pragma once

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/alignment/correlative_search.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// Where a step's pose came from.
enum class SeedSource {
  kWheels,      ///< ICP from the wheels' guess, or (recovery's incumbent) the best pose the wheels allow
  kTracked,     ///< ICP from the last matched scan's pose carried on by the wheels
  kPredicted,   ///< ICP from the motion model's prediction (the laser's own velocity)
  kSearched,    ///< ICP from a correlative search's best pose
  kSearchGrid,  ///< a correlative search's own best pose (on its grid)
  kRealigned,   ///< the loop aligner's no-guess alignment (CRF-match, ICP, validation)
};
const char* seedSourceName(SeedSource source);

/// One pose a step could take.
struct SeedCandidate {
  SeedSource source = SeedSource::kWheels;
  Pose2 pose;
  /// correlativeScore of the scan there (0..1); a candidate that is none (its ICP failed, or it
  /// lies outside the window searched) scores below 0 and never wins.
  double score = -1.0;
};

/// The one rule: candidates in order of trust, the first the incumbent; each next one replaces
/// the choice so far when it scores at least `margin` more. A less trusted seed so wins only
/// where the scans clearly say so, and ties (a corridor, where every seed fits) go to the more
/// trusted one. Returns the index chosen (0 for an empty list).
std::size_t selectSeed(const std::vector<SeedCandidate>& candidates, double margin);

/// The measure, with the target's likelihood field built on first use (most steps need none).
class SeedScorer {
 public:
  /// `target` must outlive the scorer.
  SeedScorer(const Points2& target, const CorrelativeSearchOptions& options) : target_(&target), options_(options) {}
  /// A field already built (of the target, with these options).
  SeedScorer(std::shared_ptr<const LikelihoodField> field, const CorrelativeSearchOptions& options)
      : options_(options), field_(std::move(field)) {}
  const LikelihoodField& field() const;
  /// correlativeScore of `scan` at `pose` (options.max_points strided points).
  double score(const Points2& scan, const Pose2& pose) const;

 private:
  const Points2* target_ = nullptr;
  CorrelativeSearchOptions options_;
  mutable std::shared_ptr<const LikelihoodField> field_;
};

}  // namespace llc
