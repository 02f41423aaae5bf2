// Labelled scan pairs from ground-truth poses, and the pair CSV file (header a,b,label).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

struct LabeledPair {
  std::size_t a = 0;  ///< scan index
  std::size_t b = 0;  ///< scan index, a < b
  int label = 0;      ///< 1 = same place, 0 = not
};

struct PairLabelingOptions {
  double positive_max_distance = 1.5;     ///< m; a positive pair is closer than this
  double positive_max_heading = M_PI / 4;  ///< rad; ... and within this heading (partial scans)
  bool full_circle = false;               ///< 360-degree scans: any heading may be positive
  std::size_t min_index_gap = 30;         ///< scans; a positive pair is at least this far apart
  double negative_min_distance = 10.0;    ///< m; a negative pair is farther than this
  std::size_t max_pairs_per_class = 200;  ///< at most this many of each class
  std::uint64_t seed = 1;                 ///< seeds the sampling

  [[nodiscard]] std::string validate() const;
};

struct PairLabelingResult {
  std::vector<LabeledPair> pairs;  ///< balanced: as many positives as negatives, sorted by (a, b)
  std::size_t positive_candidates = 0;  ///< every pair that met the positive rule
};

/// Balanced, seeded sampling: n = min(max_pairs_per_class, positive candidates) positives
/// drawn from all positive candidates, and n negatives drawn uniformly among the pairs
/// farther than negative_min_distance.
PairLabelingResult labelPairs(const std::vector<Pose2>& poses, const PairLabelingOptions& options);

/// Up to `count` negative pairs (a < b) drawn uniformly, seeded and without repeats, among the
/// pairs whose poses are farther apart than min_distance: all of them, in random order, when
/// there are not more. For measuring a false-alarm rate on more negatives than a balanced set
/// holds (labelPairs draws as many negatives as positives).
std::vector<LabeledPair> sampleNegativePairs(const std::vector<Pose2>& poses, double min_distance, std::size_t count,
                                             std::uint64_t seed);

/// Thrown for an unreadable or malformed pair file; what() names file and line.
class PairFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

void writePairs(const std::string& path, const std::vector<LabeledPair>& pairs);
/// Reads a pair file; every index must be below scan_count (pass SIZE_MAX to skip the check).
std::vector<LabeledPair> readPairs(const std::string& path, std::size_t scan_count);

}  // namespace llc
