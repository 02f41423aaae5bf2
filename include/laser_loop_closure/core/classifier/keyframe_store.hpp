// Feature vectors of every stored keyframe, kept feature-major (one contiguous array per
// scalar feature) so that one query scores all keyframes in a few linear passes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/features/features.hpp"

namespace llc {

struct LoopCandidate {
  std::size_t keyframe = 0;  ///< index in the store
  double score = 0.0;        ///< normalised strong-classifier score
};

/// Keyframe features are kept in single precision (half the memory a query streams through);
/// every score below is the classifier on pairFeatures(set, query, stored keyframe), the
/// stored keyframe being its features rounded to float (feature() returns them).
class KeyframeStore {
 public:
  /// Stores featureCount(set) values per keyframe; classifiers index pairFeatures(set, ...).
  explicit KeyframeStore(FeatureSet set);

  FeatureSet featureSet() const { return set_; }
  std::size_t featureCount() const { return columns_.size() + profile_size_; }
  std::size_t size() const { return size_; }
  void reserve(std::size_t keyframes);
  /// Appends a keyframe's feature vector (featureCount() values); returns its index.
  std::size_t add(const double* features);
  double feature(std::size_t keyframe, std::size_t f) const {
    return f < columns_.size() ? columns_[f][keyframe] : profiles_[keyframe * profile_size_ + f - columns_.size()];
  }
  std::vector<double> features(std::size_t keyframe) const;
  /// Bytes held for the keyframes' features (capacity reserved included).
  std::size_t bytes() const;

  /// scores[k] = classifier score of the pair (query, keyframe k) for k < limit, summed in the
  /// classifier's stump order: exactly StrongClassifier::score. Evaluates every stump on every
  /// keyframe; query() is the fast path.
  void scoreAll(const StrongClassifier& classifier, const double* query, std::size_t limit,
                std::vector<double>* scores) const;

  /// Keyframes k < limit with score >= K, best first (ties: lower index first), at most
  /// max_candidates of them. Cheap stumps run first and a keyframe is dropped as soon as the
  /// stumps still to come cannot lift it to the bar (K, or the lowest of max_candidates scores
  /// already found once there are that many), so the costly ones (signatures, profile) run on
  /// few keyframes; a small max_candidates is therefore faster. Scores agree with
  /// scoreAll to rounding (the sum runs in another order). `threads` > 1 splits the keyframes
  /// among that many threads (the calling one included); the result does not depend on it.
  std::vector<LoopCandidate> query(const StrongClassifier& classifier, const double* query,
                                   std::size_t limit, std::size_t max_candidates,
                                   std::size_t threads = 1) const;

 private:
  void checkClassifier(const StrongClassifier& classifier) const;

  FeatureSet set_;
  std::vector<std::vector<float>> columns_;  ///< scalar features, one array each
  std::size_t profile_size_;                 ///< range-profile values per keyframe
  std::vector<float> profiles_;              ///< range profiles, keyframe after keyframe
  std::vector<std::uint64_t> profile_presence_;  ///< profilePresence of each keyframe's profile
  std::vector<std::vector<double>> magnitudes_;  ///< per signature: signatureMagnitude of each keyframe's stored values
  std::size_t size_ = 0;
};

}  // namespace llc
