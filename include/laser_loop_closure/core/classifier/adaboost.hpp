// AdaBoost with decision stumps, exactly as Algorithm 1 of the paper.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace llc {

/// A weak classifier: says "match" (1) iff polarity * F[feature] < polarity * threshold.
struct Stump {
  int feature = 0;         ///< index into the pair feature vector
  int polarity = 1;        ///< +1 or -1
  double threshold = 0.0;  ///< lambda
  double alpha = 0.0;      ///< log(1 / beta_t), its weight in the strong classifier

  bool vote(const double* pair_features) const { return votesMatch(pair_features[feature]); }
  /// The vote on a value of its feature.
  bool votesMatch(double value) const { return polarity * value < polarity * threshold; }
};

/// The strong classifier: match iff sum_t alpha_t c_t(F) >= K sum_t alpha_t.
class StrongClassifier {
 public:
  StrongClassifier() = default;
  StrongClassifier(std::vector<Stump> stumps, double threshold_k);

  /// Normalised score sum_t alpha_t c_t(F) / sum_t alpha_t, in [0, 1] (0 with no stump).
  double score(const double* pair_features) const;
  bool isMatch(const double* pair_features) const { return score(pair_features) >= threshold_k_; }

  /// The classifier made of the first `rounds` stumps (what training for that many gives).
  StrongClassifier prefix(std::size_t rounds) const;

  const std::vector<Stump>& stumps() const { return stumps_; }
  double thresholdK() const { return threshold_k_; }
  void setThresholdK(double k) { threshold_k_ = k; }
  double alphaSum() const { return alpha_sum_; }
  /// Largest feature index used plus one (0 with no stump).
  std::size_t featuresNeeded() const;

 private:
  std::vector<Stump> stumps_;
  double threshold_k_ = 0.5;
  double alpha_sum_ = 0.0;
};

/// Labelled pair feature vectors, row-major: row i is features[i * dimension ...].
struct TrainingSet {
  std::size_t dimension = 0;
  std::vector<double> features;
  std::vector<int> labels;  ///< 1 = same place, 0 = not

  std::size_t size() const { return labels.size(); }
  const double* row(std::size_t i) const { return features.data() + i * dimension; }
  void add(const double* pair_features, int label);
  /// Appends every row of `other`, which must have the same dimension (std::invalid_argument).
  void append(const TrainingSet& other);
  /// Rows picked by index, in that order.
  TrainingSet subset(const std::vector<std::size_t>& rows) const;
};

struct AdaBoostOptions {
  int rounds = 50;  ///< T, the number of stumps (the paper: 50)
  /// Features the stumps may use (empty = all); Table I test 2 removes one at a time.
  std::vector<int> allowed_features;
  /// Smallest weighted error a stump is credited with, so that a perfect stump gets a finite
  /// alpha = log((1 - e) / e) instead of infinity.
  double min_error = 1e-10;

  [[nodiscard]] std::string validate() const;
};

/// What one training round did (Table I test 1 reads these).
struct RoundRecord {
  Stump stump;
  double weighted_error = 0.0;  ///< epsilon_t
};

struct AdaBoostResult {
  StrongClassifier classifier;
  std::vector<RoundRecord> rounds;
  /// Empty when training ran all rounds; otherwise why it stopped early (e.g. one class only,
  /// or no stump better than chance).
  std::string stopped_early;
};

/// Trains by Algorithm 1: weights 1/(2 N_n) and 1/(2 N_p), then per round normalise, pick the
/// stump of least weighted error by a sweep over sorted feature values, beta = e / (1 - e),
/// w_i <- w_i beta^(1 - e_i), alpha = log(1 / beta). K of the result is 0.5.
class AdaBoostTrainer {
 public:
  /// Throws std::invalid_argument when options.validate() is not empty.
  explicit AdaBoostTrainer(const AdaBoostOptions& options = {});
  AdaBoostResult train(const TrainingSet& data) const;

 private:
  AdaBoostOptions options_;
};

}  // namespace llc
