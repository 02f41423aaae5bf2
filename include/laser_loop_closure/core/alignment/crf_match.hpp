// CRF-match (Ramos, Fox & Durrant-Whyte, RSS 2007): associates the points of two scans with no
// initial guess. A linear-chain conditional random field runs along the contour of the source
// scan; each node's hidden state is the target node it corresponds to, or "outlier". Local
// features compare rotation- and translation-invariant shape descriptions at several scales,
// pairwise features reward preserved distances and consistent order. MAP association by
// max-product, confidences by sum-product; the rigid transform by robust weighted least
// squares on the confident associations.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/point_cloud.hpp"
#include "laser_loop_closure/core/geometry/rigid_fit.hpp"

namespace llc {

/// Scales of the shape descriptions, metres of arc along the contour.
constexpr std::array<double, 3> kCrfScales = {0.5, 1.0, 2.0};
/// Features per (node, state): chord and angle per scale, contour extent; see CrfWeights.
constexpr std::size_t kCrfLocalFeatures = 2 * kCrfScales.size() + 1;
/// All weights: local ones, then outlier, distance, order.
constexpr std::size_t kCrfWeights = kCrfLocalFeatures + 3;

/// Weights of the feature functions (energies: lower is more likely). The defaults are set by
/// hand (coarse scales and chords weigh most); `llc train-crf` learns weights from aligned
/// pairs (see README for how the two compare). Any non-negative values are valid.
struct CrfWeights {
  /// local: chord[s] compares the distances from a node to the contour points s metres before
  /// and after it; angle[s] the angle they make at the node; extent how far the contour
  /// reaches on either side (up to 3 m).
  std::array<double, kCrfLocalFeatures> local = {2.0, 1.2, 0.6, 0.8, 0.5, 0.3, 0.4};
  double outlier = 1.0;   ///< energy of the outlier state (the scale of all the others)
  double distance = 2.0;  ///< |distance between consecutive source nodes - that of their partners|
  double order = 0.5;     ///< partners of consecutive nodes not consecutive (0..1)

  std::array<double, kCrfWeights> asArray() const;
  static CrfWeights fromArray(const std::array<double, kCrfWeights>& values);
};

struct CrfMatchOptions {
  double node_spacing = 0.3;      ///< m of arc between chain nodes along each contour
  std::size_t max_nodes = 150;    ///< more would be needed: the spacing grows to fit
  double break_distance = 0.6;    ///< m; consecutive points farther apart start a new contour
  double min_contour_length = 0.2;  ///< m; shorter contours (clutter) get no node
  std::size_t candidates = 12;    ///< states per node kept (best local energy), plus outlier
  double temperature = 0.3;       ///< marginals ~ exp(-energy / temperature)
  double min_confidence = 0.05;   ///< associations less probable than this do not enter the fit
  std::size_t min_associations = 4;  ///< fewer confident associations: no transform
  RobustFitOptions fit{};         ///< the robust rigid fit on the associations
  CrfWeights weights{};
  [[nodiscard]] std::string validate() const;
};

/// A scan as CRF-match sees it: nodes spaced along its contours, with their descriptions.
struct CrfScan {
  Points2 nodes;
  /// Per node: chord(-s), chord(+s), angle per scale, then extent(-), extent(+);
  /// NaN where the contour does not reach far enough.
  std::vector<std::array<double, 3 * kCrfScales.size() + 2>> descriptors;
};

/// Nodes and descriptions of one scan's points (in beam order, as scanPoints gives them).
CrfScan describeForCrf(const Points2& points, const CrfMatchOptions& options);

/// The local feature values of source node i in state j (target node j).
std::array<double, kCrfLocalFeatures> crfLocalFeatures(const CrfScan& source, std::size_t i, const CrfScan& target,
                                                       std::size_t j);

struct CrfMatchResult {
  bool ok = false;
  Pose2 pose;                               ///< source frame in the target frame
  std::vector<Pose2> alternatives;          ///< runners-up of the robust fit, best first
  std::vector<long> association;            ///< per source node: target node, or -1 (outlier)
  std::vector<double> confidence;           ///< per source node: marginal of its MAP state
  std::size_t confident = 0;                ///< associations that entered the fit
  std::size_t inliers = 0;                  ///< of those, consistent with the transform
  double seconds = 0.0;
  std::string reject_reason;
};

/// Associates source with target; `forced` (one state per source node, -1 = outlier) may be
/// given to keep those states among the candidates, as training needs.
CrfMatchResult matchCrf(const CrfScan& source, const CrfScan& target, const CrfMatchOptions& options,
                        const std::vector<long>* forced = nullptr);

/// Summed feature values of an association (what the energy is linear in), kCrfWeights long.
std::array<double, kCrfWeights> crfFeatureTotals(const CrfScan& source, const CrfScan& target,
                                                  const std::vector<long>& association);

/// The true association under a known pose: each source node's nearest target node within
/// `max_distance`, else -1.
std::vector<long> crfTrueAssociation(const CrfScan& source, const CrfScan& target, const Pose2& pose,
                                     double max_distance);

}  // namespace llc
