// Learning CRF-match's weights from aligned pairs (averaged structured perceptron), and the
// weights file (YAML, versioned).
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/crf_match.hpp"

namespace llc {

/// One training pair: source and target scans and the true pose of source in target's frame.
struct CrfTrainingPair {
  const CrfScan* source = nullptr;
  const CrfScan* target = nullptr;
  Pose2 truth;
};

struct CrfTrainingOptions {
  int epochs = 8;                 ///< passes over the pairs
  double learning_rate = 0.05;    ///< perceptron step
  double truth_distance = 0.3;    ///< m; a source node's true partner is the target node within this
  std::uint64_t seed = 1;         ///< seeds the order of the pairs in each pass
  [[nodiscard]] std::string validate() const;
};

struct CrfTrainingResult {
  CrfWeights weights;                   ///< averaged, scaled so that outlier = 1
  std::vector<double> error_by_epoch;   ///< share of nodes whose MAP state was wrong, per pass
};

/// Averaged structured perceptron on the energy (linear in the weights): where the MAP
/// association differs from the true one, weights move by the difference of their feature
/// totals; weights stay >= 0.
CrfTrainingResult trainCrfWeights(const std::vector<CrfTrainingPair>& pairs, const CrfMatchOptions& start,
                                  const CrfTrainingOptions& options);

class CrfWeightsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
constexpr int kCrfWeightsVersion = 1;
void saveCrfWeights(const CrfWeights& weights, const std::map<std::string, std::string>& provenance,
                    const std::string& path);
/// Throws CrfWeightsError naming the file on a missing, corrupt, truncated or other-version file.
CrfWeights loadCrfWeights(const std::string& path);

}  // namespace llc
