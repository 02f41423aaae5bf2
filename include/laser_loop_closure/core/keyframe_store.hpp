// Feature vectors of every stored keyframe, kept feature-major (one contiguous array per
// feature) so that one query scores all keyframes in a few linear passes.
#pragma once

#include <cstddef>
#include <vector>

#include "laser_loop_closure/core/adaboost.hpp"
#include "laser_loop_closure/core/features.hpp"

namespace llc {

struct LoopCandidate {
  std::size_t keyframe = 0;  ///< index in the store
  double score = 0.0;        ///< normalised strong-classifier score
};

class KeyframeStore {
 public:
  /// Stores featureCount(set) values per keyframe; classifiers index pairFeatures(set, ...).
  explicit KeyframeStore(FeatureSet set);

  std::size_t featureCount() const { return columns_.size(); }
  std::size_t size() const { return size_; }
  void reserve(std::size_t keyframes);
  /// Appends a keyframe's feature vector (featureCount() values); returns its index.
  std::size_t add(const double* features);
  double feature(std::size_t keyframe, std::size_t f) const { return columns_[f][keyframe]; }

  /// scores[k] = classifier score of the pair (query, keyframe k) for k < limit; the same
  /// number StrongClassifier::score gives on pairFeatures(set, query, keyframe).
  void scoreAll(const StrongClassifier& classifier, const double* query, std::size_t limit,
                std::vector<double>* scores) const;

  /// Keyframes k < limit with score >= K, best first, at most max_candidates of them.
  std::vector<LoopCandidate> query(const StrongClassifier& classifier, const double* query,
                                   std::size_t limit, std::size_t max_candidates) const;

 private:
  FeatureSet set_;
  std::vector<std::vector<double>> columns_;
  std::size_t size_ = 0;
};

}  // namespace llc
