#include "laser_loop_closure/core/keyframe_store.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace llc {

KeyframeStore::KeyframeStore(FeatureSet set) : set_(set), columns_(llc::featureCount(set)) {}

void KeyframeStore::reserve(std::size_t keyframes) {
  for (auto& column : columns_) column.reserve(keyframes);
}

std::size_t KeyframeStore::add(const double* features) {
  for (std::size_t f = 0; f < columns_.size(); ++f) columns_[f].push_back(features[f]);
  return size_++;
}

void KeyframeStore::scoreAll(const StrongClassifier& classifier, const double* query,
                             std::size_t limit, std::vector<double>* scores) const {
  if (classifier.featuresNeeded() > pairFeatureCount(set_))
    throw std::invalid_argument("keyframe store: the classifier needs more features than stored");
  limit = std::min(limit, size_);
  scores->assign(limit, 0.0);
  if (classifier.alphaSum() <= 0.0) return;
  // Blocks small enough that the partial sums stay in the first-level cache while every stump
  // passes over them; each stump is a branch-free compare-and-add the compiler vectorises.
  constexpr std::size_t kBlock = 2048;
  const double alpha_sum = classifier.alphaSum();
  const std::size_t n = columns_.size();
  const std::size_t signatures = signatureCount(set_), offset = signatureOffset(set_);
  // Signature distances are computed per block only for the signatures some stump uses.
  std::vector<bool> used(signatures, false);
  for (const Stump& s : classifier.stumps())
    if (std::size_t(s.feature) >= 2 * n) used[(std::size_t(s.feature) - 2 * n) % signatures] = true;
  std::vector<double> distance(signatures * kBlock), scale(signatures * kBlock);
  double* out = scores->data();
  for (std::size_t begin = 0; begin < limit; begin += kBlock) {
    const std::size_t end = std::min(limit, begin + kBlock), width = end - begin;
    for (std::size_t g = 0; g < signatures; ++g) {
      if (!used[g]) continue;
      double* d = distance.data() + g * kBlock;
      double* w = scale.data() + g * kBlock;
      std::fill(d, d + width, 0.0);
      std::fill(w, w + width, 0.0);
      for (std::size_t q = 0; q < kSignatureLevels; ++q) {  // same order as signatureDistance
        const double* column = columns_[offset + g * kSignatureLevels + q].data() + begin;
        const double v = query[offset + g * kSignatureLevels + q];
        const double v_abs = v < 0 ? -v : v;
        for (std::size_t k = 0; k < width; ++k) {
          const double c = column[k];
          d[k] += v > c ? v - c : c - v;
          w[k] += v_abs + (c < 0 ? -c : c);
        }
      }
    }
    for (const Stump& s : classifier.stumps()) {
      const std::size_t f = std::size_t(s.feature);
      const double bound = s.polarity * s.threshold;
      const double polarity = s.polarity, alpha = s.alpha;
      if (f < 2 * n) {
        const double* column = columns_[f % n].data();
        const double q = query[f % n];
        for (std::size_t k = begin; k < end; ++k)
          out[k] += (polarity * pairFeatureValue(f, n, q, column[k]) < bound) ? alpha : 0.0;
      } else {
        const std::size_t g = (f - 2 * n) % signatures;
        const bool relative = f - 2 * n >= signatures;
        const double* d = distance.data() + g * kBlock;
        const double* w = scale.data() + g * kBlock;
        for (std::size_t k = 0; k < width; ++k) {
          const double value = relative ? (w[k] > 0.0 ? d[k] / w[k] : 0.0) : d[k] / double(kSignatureLevels);
          out[begin + k] += (polarity * value < bound) ? alpha : 0.0;
        }
      }
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
