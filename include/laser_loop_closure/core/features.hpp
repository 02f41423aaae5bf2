// Rotation-invariant features of one scan: the paper's 20 (section III-B, restated in
// shared/seed/READING-NOTES.md) and the project's extended set.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/scan.hpp"

namespace llc {

/// Which features a scan is described by.
enum class FeatureSet {
  kPaper,     ///< the paper's 20 features, in the paper's order
  kExtended,  ///< the paper's 20 followed by the project's additions (the default)
};

const char* toString(FeatureSet set);
/// Parses "paper" or "extended"; returns false on anything else.
bool parseFeatureSet(const std::string& text, FeatureSet* set);

struct FeatureOptions {
  double r_max = 50.0;       ///< m; beams at or beyond it (or with no finite return) are max-range
  double g_max_dist = 2.5;   ///< m; gate on the distance between consecutive points (#5, #12, #13)
  int g_min_size = 3;        ///< points; a cluster is a group only with more points than this
  /// For scans marked full_circle: the last beam neighbours the first, so every feature is
  /// invariant to a cyclic shift of the beams. Partial scans are never closed.
  bool closed_ring = true;
  FeatureSet feature_set = FeatureSet::kExtended;  ///< which features to compute

  /// Empty when the options are usable, else a sentence saying what is wrong.
  std::string validate() const;
  bool operator==(const FeatureOptions& other) const;
  bool operator!=(const FeatureOptions& other) const { return !(*this == other); }
};

/// Number of features in a set (20 for the paper's).
std::size_t featureCount(FeatureSet set);
/// Short snake_case names, in order (feature i of the vector is names[i]).
const std::vector<std::string>& featureNames(FeatureSet set);

/// Computes feature vectors. Not thread-safe (it caches the beam trigonometry of the last
/// bearing layout, since every scan of one scanner shares it): give each thread its own.
class FeatureExtractor {
 public:
  /// Throws std::invalid_argument when options.validate() is not empty.
  explicit FeatureExtractor(const FeatureOptions& options = {});

  const FeatureOptions& options() const { return options_; }
  std::size_t size() const { return featureCount(options_.feature_set); }

  /// Writes size() finite values to out, whatever the ranges hold.
  void extract(const Scan& scan, double* out);
  std::vector<double> extract(const Scan& scan);

 private:
  void updateTrigonometry(const std::vector<double>& bearings);

  FeatureOptions options_;
  std::vector<double> cached_bearings_, cos_, sin_;
  // Work arrays, kept to avoid allocating per scan.
  std::vector<double> clipped_, x_, y_, segment_, sorted_, curvature_;
  std::vector<unsigned char> valid_;
};

/// Pair feature vector of the paper: element-wise |a_i - b_i|.
void pairFeatures(const double* a, const double* b, std::size_t size, double* out);
std::vector<double> pairFeatures(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace llc
