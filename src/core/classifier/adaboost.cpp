#include "laser_loop_closure/core/classifier/adaboost.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace llc {

StrongClassifier::StrongClassifier(std::vector<Stump> stumps, double threshold_k)
    : stumps_(std::move(stumps)), threshold_k_(threshold_k) {
  for (const Stump& s : stumps_) alpha_sum_ += s.alpha;
}

double StrongClassifier::score(const double* pair_features) const {
  if (alpha_sum_ <= 0.0) return 0.0;
  double sum = 0.0;
  for (const Stump& s : stumps_)
    if (s.vote(pair_features)) sum += s.alpha;
  return sum / alpha_sum_;
}

StrongClassifier StrongClassifier::prefix(std::size_t rounds) const {
  rounds = std::min(rounds, stumps_.size());
  return StrongClassifier(std::vector<Stump>(stumps_.begin(), stumps_.begin() + long(rounds)),
                          threshold_k_);
}

std::size_t StrongClassifier::featuresNeeded() const {
  std::size_t needed = 0;
  for (const Stump& s : stumps_) needed = std::max(needed, std::size_t(s.feature) + 1);
  return needed;
}

void TrainingSet::add(const double* pair_features, int label) {
  features.insert(features.end(), pair_features, pair_features + dimension);
  labels.push_back(label);
}

void TrainingSet::append(const TrainingSet& other) {
  if (other.dimension != dimension)
    throw std::invalid_argument("training set: rows of " + std::to_string(other.dimension) + " values appended to rows of " +
                                std::to_string(dimension));
  features.insert(features.end(), other.features.begin(), other.features.end());
  labels.insert(labels.end(), other.labels.begin(), other.labels.end());
}

TrainingSet TrainingSet::subset(const std::vector<std::size_t>& rows) const {
  TrainingSet out;
  out.dimension = dimension;
  out.features.reserve(rows.size() * dimension);
  out.labels.reserve(rows.size());
  for (std::size_t r : rows) out.add(row(r), labels[r]);
  return out;
}

std::string AdaBoostOptions::validate() const {
  if (rounds < 1) return "rounds must be at least 1";
  if (!(min_error > 0.0 && min_error < 0.5)) return "min_error must lie in (0, 0.5)";
  for (int f : allowed_features)
    if (f < 0) return "allowed_features must be feature indices (0 or more)";
  return {};
}

AdaBoostTrainer::AdaBoostTrainer(const AdaBoostOptions& options) : options_(options) {
  const std::string error = options_.validate();
  if (!error.empty()) throw std::invalid_argument("AdaBoost options: " + error);
}

AdaBoostResult AdaBoostTrainer::train(const TrainingSet& data) const {
  AdaBoostResult result;
  const std::size_t n = data.size(), dim = data.dimension;
  std::size_t positives = 0;
  for (int y : data.labels) positives += (y == 1);
  const std::size_t negatives = n - positives;
  if (positives == 0 || negatives == 0) {
    result.stopped_early = "training needs both matching and non-matching pairs";
    return result;
  }
  std::vector<int> features = options_.allowed_features;
  if (features.empty()) {
    features.resize(dim);
    std::iota(features.begin(), features.end(), 0);
  }
  features.erase(std::remove_if(features.begin(), features.end(),
                                [dim](int f) { return std::size_t(f) >= dim; }),
                 features.end());

  // Each feature's samples sorted once; every round sweeps them in this order.
  std::vector<std::vector<std::size_t>> order(features.size());
  for (std::size_t k = 0; k < features.size(); ++k) {
    order[k].resize(n);
    std::iota(order[k].begin(), order[k].end(), 0);
    const int f = features[k];
    std::stable_sort(order[k].begin(), order[k].end(), [&](std::size_t a, std::size_t b) {
      return data.row(a)[f] < data.row(b)[f];
    });
  }

  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i)
    w[i] = data.labels[i] == 1 ? 1.0 / (2.0 * double(positives)) : 1.0 / (2.0 * double(negatives));

  std::vector<Stump> stumps;
  for (int t = 0; t < options_.rounds; ++t) {
    const double total = std::accumulate(w.begin(), w.end(), 0.0);
    double total_pos = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      w[i] /= total;
      if (data.labels[i] == 1) total_pos += w[i];
    }
    const double total_neg = 1.0 - total_pos;

    Stump best;
    double best_error = 2.0;
    for (std::size_t k = 0; k < features.size(); ++k) {
      const int f = features[k];
      const std::vector<std::size_t>& idx = order[k];
      // Threshold below every value: nothing is below, so p=+1 says 0 for all, p=-1 says 1.
      double below_pos = 0.0, below_neg = 0.0;
      auto consider = [&](double threshold) {
        const double error_plus = below_neg + (total_pos - below_pos);   // below -> match
        const double error_minus = below_pos + (total_neg - below_neg);  // above -> match
        if (error_plus < best_error) best_error = error_plus, best = {f, 1, threshold, 0.0};
        if (error_minus < best_error) best_error = error_minus, best = {f, -1, threshold, 0.0};
      };
      const double lowest = data.row(idx.front())[f];
      consider(lowest - std::max(1.0, std::abs(lowest)));
      for (std::size_t s = 0; s < n; ++s) {
        const std::size_t i = idx[s];
        (data.labels[i] == 1 ? below_pos : below_neg) += w[i];
        const double value = data.row(i)[f];
        if (s + 1 < n) {
          const double following = data.row(idx[s + 1])[f];
          if (following > value) consider(0.5 * (value + following));  // between distinct values
        } else {
          consider(value + std::max(1.0, std::abs(value)));  // above every value
        }
      }
    }

    RoundRecord record;
    record.weighted_error = best_error;
    if (!(best_error < 0.5)) {
      result.stopped_early = "no stump better than chance after " + std::to_string(t) + " rounds";
      break;
    }
    const double error = std::max(best_error, options_.min_error);
    const double beta = error / (1.0 - error);
    best.alpha = std::log(1.0 / beta);
    for (std::size_t i = 0; i < n; ++i) {
      const bool correct = int(best.vote(data.row(i))) == data.labels[i];
      if (correct) w[i] *= beta;  // w <- w beta^(1 - e_i), e_i = 0 when correct
    }
    record.stump = best;
    result.rounds.push_back(record);
    stumps.push_back(best);
  }
  result.classifier = StrongClassifier(std::move(stumps), 0.5);
  return result;
}

}  // namespace llc
