#include "laser_loop_closure/core/keyframe_store.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace llc {

KeyframeStore::KeyframeStore(std::size_t feature_count) : columns_(feature_count) {}

void KeyframeStore::reserve(std::size_t keyframes) {
  for (auto& column : columns_) column.reserve(keyframes);
}

std::size_t KeyframeStore::add(const double* features) {
  for (std::size_t f = 0; f < columns_.size(); ++f) columns_[f].push_back(features[f]);
  return size_++;
}

void KeyframeStore::scoreAll(const StrongClassifier& classifier, const double* query,
                             std::size_t limit, std::vector<double>* scores) const {
  if (classifier.featuresNeeded() > columns_.size())
    throw std::invalid_argument("keyframe store: the classifier needs more features than stored");
  limit = std::min(limit, size_);
  scores->assign(limit, 0.0);
  if (classifier.alphaSum() <= 0.0) return;
  // Blocks small enough that the partial sums stay in the first-level cache while every stump
  // passes over them; each stump is a branch-free compare-and-add the compiler vectorises.
  constexpr std::size_t kBlock = 2048;
  const double alpha_sum = classifier.alphaSum();
  double* out = scores->data();
  for (std::size_t begin = 0; begin < limit; begin += kBlock) {
    const std::size_t end = std::min(limit, begin + kBlock);
    for (const Stump& s : classifier.stumps()) {
      const double* column = columns_[std::size_t(s.feature)].data();
      const double q = query[s.feature];
      const double bound = s.polarity * s.threshold;
      const double polarity = s.polarity, alpha = s.alpha;
      for (std::size_t k = begin; k < end; ++k)
        out[k] += (polarity * std::abs(q - column[k]) < bound) ? alpha : 0.0;
    }
    for (std::size_t k = begin; k < end; ++k) out[k] /= alpha_sum;  // as StrongClassifier::score
  }
}

std::vector<LoopCandidate> KeyframeStore::query(const StrongClassifier& classifier,
                                                const double* query, std::size_t limit,
                                                std::size_t max_candidates) const {
  std::vector<double> scores;
  scoreAll(classifier, query, limit, &scores);
  std::vector<LoopCandidate> candidates;
  for (std::size_t k = 0; k < scores.size(); ++k)
    if (scores[k] >= classifier.thresholdK()) candidates.push_back({k, scores[k]});
  const std::size_t keep = std::min(max_candidates, candidates.size());
  std::partial_sort(candidates.begin(), candidates.begin() + long(keep), candidates.end(),
                    [](const LoopCandidate& a, const LoopCandidate& b) {
                      return a.score > b.score || (a.score == b.score && a.keyframe < b.keyframe);
                    });
  candidates.resize(keep);
  return candidates;
}

}  // namespace llc
