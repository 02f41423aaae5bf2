// Rotation-invariant features of one scan: the paper's 20 (section III-B, restated in
// shared/seed/READING-NOTES.md) and the project's extended set.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "laser_loop_closure/core/common/rank_selection.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"

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
  [[nodiscard]] std::string validate() const;
  bool operator==(const FeatureOptions& other) const;
  bool operator!=(const FeatureOptions& other) const { return !(*this == other); }
};

/// The paper's 20 features by name, in the paper's order (#1 is kArea): slot i of every
/// feature vector is featureNames()[i].
enum class PaperFeature : std::size_t {
  kArea, kAverageRange, kCentroid, kCloseArea, kCloseDistance, kCircleRadius, kCircleResidual,
  kCurvatureMean, kCurvatureStd, kDistance, kFarDistance, kGroupCount, kGroupSizeMean, kMaxRangeCount,
  kAngularDifference, kMeanDeviation, kRegularity, kSize, kDeviationStd, kRangeStd,
  kCount
};

/// Bins of the extended set's range histogram: [0,1) [1,2) [2,4) [4,8) [8,16) [16,r_max) m.
constexpr std::size_t kRangeHistogramBins = 6;

/// The extended set's scalar additions by name; they follow the paper's 20.
enum class ExtraFeature : std::size_t {
  kValidFraction, kMaxRangeFraction, kGroupSizeFraction,
  kRangeQ10, kRangeQ25, kRangeQ50, kRangeQ75, kRangeQ90,
  kPrincipalSigmaMajor, kPrincipalSigmaMinor, kAnisotropy,
  kGapCount, kWidestGapAngle, kLongestGroupLength, kGroupLengthMean,
  kRangeHistogram,  ///< the first of kRangeHistogramBins fractions of the beams
  kCount = kRangeHistogram + kRangeHistogramBins
};

/// The extended set's signatures by name, stored after the scalar additions.
enum class Signature : std::size_t { kRange, kCentroidDistance, kChord, kOutlineD2, kOutlineCentroidDistance, kCount };

/// Where a named feature sits in a feature vector.
constexpr std::size_t featureIndex(PaperFeature feature) { return std::size_t(feature); }
constexpr std::size_t featureIndex(ExtraFeature feature) {
  return std::size_t(PaperFeature::kCount) + std::size_t(feature);
}

/// Number of values in a scan's feature vector (20 for the paper's).
std::size_t featureCount(FeatureSet set);
/// The first scalarFeatureCount(set) of them are rotation-invariant numbers whose pair
/// features are differences; the extended set's range profile (kProfileSectors values from
/// profileOffset(set)) follows them and is compared only as a whole, at the best rotation.
std::size_t scalarFeatureCount(FeatureSet set);
std::size_t profileOffset(FeatureSet set);

/// Signatures (extended set only): distributions stored inside the feature vector as
/// kSignatureLevels quantiles each, from signatureOffset(set) on.
constexpr std::size_t kSignatureLevels = 16;
constexpr std::size_t kSignatureCount = std::size_t(Signature::kCount);
std::size_t signatureCount(FeatureSet set);
std::size_t signatureOffset(FeatureSet set);
/// Wasserstein-1 distance of two signatures (the mean absolute difference of their
/// quantiles); relative = that sum divided by signatureMagnitude(a) + signatureMagnitude(b)
/// (kind 1), so that a store of signatures can keep each one's magnitude.
double signatureDistance(std::size_t kind, const double* a, const double* b);
/// Sum of the absolute quantiles of one signature, in quantile order.
double signatureMagnitude(const double* signature);
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
  struct Shape;  // what the blocks below share (features.cpp)

  void updateTrigonometry(const std::vector<double>& bearings);
  // The blocks of extract(), in the order it calls them: each measures one aspect of the
  // scan into the Shape, or writes named features from it.
  Shape measureBeams(const Scan& scan);
  void measureNeighbours(Shape& shape);
  void measureTriples(Shape& shape);
  void measureGroups(Shape& shape);
  void measureMoments(Shape& shape);
  static void writePaperFeatures(const Shape& shape, double* out);
  void writeExtraFeatures(const Shape& shape, double* out);
  void writeGaps(const Shape& shape, double* out);
  void writeRangeHistogram(const Shape& shape, double* out) const;
  /// Puts the valid beams' entries of values into ranks_ and returns their number.
  std::size_t rankValid(const Shape& shape, const double* values);
  void writeRangeDistribution(const Shape& shape, double* out);
  void writeChordSignature(const Shape& shape, double* out);
  /// The two outline signatures (outline.hpp) of the points in x_, y_ into out.
  void writeOutlineSignatures(bool closed, std::size_t n, double* out);

  FeatureOptions options_;
  std::vector<double> cached_bearings_, cos_, sin_, half_sin_;  ///< half_sin_[i]: sin of half the step to i+1
  double seam_half_sin_ = 0.0;  ///< the same from the last beam round to the first
  // Work arrays, kept to avoid allocating per scan.
  std::vector<double> clipped_, x_, y_, step_, skip2_, segment_, centre_distance_, circle_distance_, work_, turn_, curvature_;
  std::vector<double> outline_x_, outline_y_, outline_work_;
  std::vector<std::uint8_t> linked_;  ///< per beam: joined to the next into a group (then reused for the gaps)
  std::vector<std::uint32_t> run_first_, run_last_;  ///< runs found by findRuns
  RankSelector ranks_;
  std::vector<std::size_t> sector_;  ///< range-profile sector of each beam (cached with the trigonometry)
  std::vector<unsigned char> valid_;
  std::vector<double> valid_weight_;  ///< valid_ as 1.0 / 0.0, for the vectorised sums
};

/// The pair feature vector the classifier sees, from two scans' feature vectors a and b of
/// featureCount(set) values. Paper set: the paper's |a_i - b_i|. Extended set: those over the
/// scalar features, then their relative differences |a_i - b_i| / (|a_i| + |b_i|) (0 when both
/// are 0), because how much a feature changes between two visits of one place grows with its
/// size (area, lengths); then the Wasserstein-1 distance of each signature, then its relative
/// form; last the range-profile distance at the best rotation (profileDistance).
std::size_t pairFeatureCount(FeatureSet set);
/// Index of the range-profile distance among the pair features (extended set).
std::size_t profilePairFeature(FeatureSet set);
const std::vector<std::string>& pairFeatureNames(FeatureSet set);
void pairFeatures(FeatureSet set, const double* a, const double* b, double* out);
std::vector<double> pairFeatures(FeatureSet set, const std::vector<double>& a, const std::vector<double>& b);

/// Pair feature `index` of the layout above, from the two scans' values of its scan feature.
inline double pairFeatureValue(std::size_t index, std::size_t scan_feature_count, double a, double b) {
  const double difference = a > b ? a - b : b - a;
  if (index < scan_feature_count) return difference;
  const double scale = (a < 0 ? -a : a) + (b < 0 ? -b : b);
  return scale > 0.0 ? difference / scale : 0.0;
}

}  // namespace llc
