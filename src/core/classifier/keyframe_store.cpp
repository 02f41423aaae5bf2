#include "laser_loop_closure/core/classifier/keyframe_store.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <stdexcept>
#include <thread>

#include "laser_loop_closure/core/features/range_profile.hpp"

namespace llc {
namespace {

/// Blocks small enough that the partial sums and a block of every column a stump reads stay
/// in cache while all stumps pass over them.
constexpr std::size_t kBlock = 2048;


/// Hot loops get an AVX2 twin that the loader picks on CPUs that have it (GCC target_clones).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define LLC_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define LLC_VECTOR_CLONES
#endif

enum class StumpKind { kScalar, kSignature, kProfile };

/// Which kind of pair feature a stump reads; for signatures also which one and whether relative.
struct StumpLayout {
  std::size_t scalars, signatures, profile_feature;
  StumpKind kind(std::size_t f) const {
    if (f < 2 * scalars) return StumpKind::kScalar;
    return f == profile_feature ? StumpKind::kProfile : StumpKind::kSignature;
  }
  std::size_t signature(std::size_t f) const { return (f - 2 * scalars) % signatures; }
  bool relative(std::size_t f) const { return f - 2 * scalars >= signatures; }
};

/// The float interval [lo, hi] of stored values c for which a stump on |q - c| votes "match".
/// fl(q - c) is monotone in c, so the voting values form one interval; its ends are found
/// from float(q -+ t) by stepping ulp by ulp against the stump's own test, which keeps the
/// votes identical to Stump::vote on pairFeatureValue. Empty when lo > hi.
struct FloatInterval {
  float lo, hi;
  bool inside;  ///< vote "match" inside [lo, hi] (else outside it)
};

FloatInterval absoluteStumpInterval(const Stump& s, double q) {
  // Polarity +1: |q - c| < t votes inside; -1: -|q - c| < -t, i.e. |q - c| > t, votes outside
  // the interval where |q - c| <= t.
  const double t = s.threshold;
  auto in = [&](float c) {
    const double d = std::fabs(q - double(c));
    return s.polarity > 0 ? d < t : d <= t;
  };
  const float inf = std::numeric_limits<float>::infinity();
  float lo = float(q), hi = float(q);
  if (!in(lo)) {  // t <= 0 with polarity +1, or t < 0 with -1: no value inside
    return {1.0f, 0.0f, s.polarity > 0};
  }
  // Walk outwards from float(q - t) and float(q + t) to the last values inside.
  float a = std::isfinite(q - t) ? float(q - t) : -inf, b = std::isfinite(q + t) ? float(q + t) : inf;
  a = std::max(std::min(a, lo), -std::numeric_limits<float>::max());
  b = std::min(std::max(b, hi), std::numeric_limits<float>::max());
  while (!in(a)) a = std::nextafter(a, inf);
  while (a > -std::numeric_limits<float>::max() && in(std::nextafter(a, -inf))) a = std::nextafter(a, -inf);
  while (!in(b)) b = std::nextafter(b, -inf);
  while (b < std::numeric_limits<float>::max() && in(std::nextafter(b, inf))) b = std::nextafter(b, inf);
  const bool unbounded_lo = a == -std::numeric_limits<float>::max(), unbounded_hi = b == std::numeric_limits<float>::max();
  return {unbounded_lo ? -inf : a, unbounded_hi ? inf : b, s.polarity > 0};
}

/// Adds alpha to out[k] for every keyframe k of [0, width) whose scalar stump votes "match",
/// with exactly the votes of Stump::vote on pairFeatureValue.
LLC_VECTOR_CLONES
void addScalarStump(const Stump& s, std::size_t scalars, double q, const float* column, std::size_t width,
                    double* out) {
  const double alpha = s.alpha;
  if (std::size_t(s.feature) < scalars) {  // |q - c|: a float interval test
    const FloatInterval range = absoluteStumpInterval(s, q);
    const float lo = range.lo, hi = range.hi;
    if (range.inside) {
      for (std::size_t k = 0; k < width; ++k) out[k] += (column[k] >= lo && column[k] <= hi) ? alpha : 0.0;
    } else {
      for (std::size_t k = 0; k < width; ++k) out[k] += (column[k] < lo || column[k] > hi) ? alpha : 0.0;
    }
    return;
  }
  // |q - c| / (|q| + |c|): the values pairFeatureValue gives (a - b and b - a are exact
  // negations, so fabs matches its branches; a zero scale means q = c = 0, so dividing 0 by 1
  // gives its 0) in a form the compiler vectorises, since no division is conditional.
  const double q_abs = std::fabs(q), t = s.threshold;
  if (s.polarity > 0) {
    for (std::size_t k = 0; k < width; ++k) {
      const double c = column[k], scale = q_abs + std::fabs(c);
      const double value = std::fabs(q - c) / (scale > 0.0 ? scale : 1.0);
      out[k] += value < t ? alpha : 0.0;
    }
  } else {
    for (std::size_t k = 0; k < width; ++k) {
      const double c = column[k], scale = q_abs + std::fabs(c);
      const double value = std::fabs(q - c) / (scale > 0.0 ? scale : 1.0);
      out[k] += -value < -t ? alpha : 0.0;
    }
  }
}

/// d[k] for keyframes begin..begin+width: the sum of absolute quantile differences that
/// signatureDistance forms for one signature (first_column.. its kSignatureLevels columns).
/// All of a keyframe's quantiles in one pass, the sum kept in a register: in the order of
/// signatureSum, so bit for bit the same.
LLC_VECTOR_CLONES
void addSignatureDistances(const std::vector<std::vector<float>>& columns, std::size_t first_column,
                           const double* query_signature, std::size_t begin, std::size_t width, double* d) {
  const float* column[kSignatureLevels];
  double v[kSignatureLevels];
  for (std::size_t q = 0; q < kSignatureLevels; ++q) {
    column[q] = columns[first_column + q].data() + begin;
    v[q] = query_signature[q];
  }
  for (std::size_t k = 0; k < width; ++k) {
    double sum = 0.0;
#pragma GCC unroll 16
    for (std::size_t q = 0; q < kSignatureLevels; ++q) sum += std::fabs(v[q] - double(column[q][k]));
    d[k] = sum;
  }
}

/// How many of partial[0..width) can still reach `needed` with `remaining` more alpha.
LLC_VECTOR_CLONES
std::size_t countInRace(const double* partial, std::size_t width, double remaining, double needed) {
  std::size_t in_race = 0;
  for (std::size_t k = 0; k < width; ++k) in_race += partial[k] + remaining >= needed;
  return in_race;
}

/// Signature value from the distance sum d and the two magnitudes, as signatureDistance.
inline double signatureFromSums(double d, double query_magnitude, double keyframe_magnitude, bool relative) {
  if (!relative) return d / double(kSignatureLevels);
  const double scale = query_magnitude + keyframe_magnitude;
  return scale > 0.0 ? d / scale : 0.0;
}

/// Adds alpha to out[k] for every keyframe k of [0, width) whose signature stump votes
/// "match", from the distance sums d and the keyframes' magnitudes.
LLC_VECTOR_CLONES
void addSignatureStump(const Stump& s, bool relative, const double* d, double query_magnitude,
                       const double* keyframe_magnitude, std::size_t width, double* out) {
  for (std::size_t k = 0; k < width; ++k)
    out[k] += s.votesMatch(signatureFromSums(d[k], query_magnitude, keyframe_magnitude[k], relative)) ? s.alpha : 0.0;
}

/// Signature distance sum of the query to keyframe `k`, as signatureDistance forms it.
double signatureSum(const std::vector<std::vector<float>>& columns, std::size_t first_column,
                    const double* query_signature, std::size_t k) {
  double distance = 0.0;
  for (std::size_t q = 0; q < kSignatureLevels; ++q) {
    const double v = query_signature[q], c = columns[first_column + q][k];
    distance += v > c ? v - c : c - v;
  }
  return distance;
}

}  // namespace

KeyframeStore::KeyframeStore(FeatureSet set)
    : set_(set),
      columns_(scalarFeatureCount(set)),
      profile_size_(llc::featureCount(set) - scalarFeatureCount(set)),
      magnitudes_(signatureCount(set)) {}

void KeyframeStore::reserve(std::size_t keyframes) {
  for (auto& column : columns_) column.reserve(keyframes);
  for (auto& magnitude : magnitudes_) magnitude.reserve(keyframes);
  profiles_.reserve(keyframes * profile_size_);
  if (profile_size_ > 0) profile_presence_.reserve(keyframes);
}

std::size_t KeyframeStore::bytes() const {
  std::size_t bytes = profiles_.capacity() * sizeof(float) + profile_presence_.capacity() * sizeof(std::uint64_t);
  for (const auto& column : columns_) bytes += column.capacity() * sizeof(float);
  for (const auto& magnitude : magnitudes_) bytes += magnitude.capacity() * sizeof(double);
  return bytes;
}

std::size_t KeyframeStore::add(const double* features) {
  for (std::size_t f = 0; f < columns_.size(); ++f) columns_[f].push_back(float(features[f]));
  for (std::size_t p = 0; p < profile_size_; ++p) profiles_.push_back(float(features[columns_.size() + p]));
  if (profile_size_ > 0) profile_presence_.push_back(profilePresence(profiles_.data() + size_ * profile_size_));
  // Each signature's magnitude, from the values as stored (float), for relative distances.
  const std::size_t offset = signatureOffset(set_);
  for (std::size_t g = 0; g < magnitudes_.size(); ++g) {
    double stored[kSignatureLevels];
    for (std::size_t q = 0; q < kSignatureLevels; ++q) stored[q] = double(columns_[offset + g * kSignatureLevels + q].back());
    magnitudes_[g].push_back(signatureMagnitude(stored));
  }
  return size_++;
}

std::vector<double> KeyframeStore::features(std::size_t keyframe) const {
  if (keyframe >= size_) throw std::out_of_range("keyframe store: no keyframe " + std::to_string(keyframe));
  std::vector<double> out(featureCount());
  for (std::size_t f = 0; f < out.size(); ++f) out[f] = feature(keyframe, f);
  return out;
}

void KeyframeStore::checkClassifier(const StrongClassifier& classifier) const {
  if (classifier.featuresNeeded() > pairFeatureCount(set_))
    throw std::invalid_argument("keyframe store: the classifier needs more pair features than the store's set has");
}

void KeyframeStore::scoreAll(const StrongClassifier& classifier, const double* query, std::size_t limit,
                             std::vector<double>* scores) const {
  checkClassifier(classifier);
  limit = std::min(limit, size_);
  scores->assign(limit, 0.0);
  if (classifier.alphaSum() <= 0.0) return;
  const std::size_t n = columns_.size();
  const StumpLayout layout{n, signatureCount(set_), profilePairFeature(set_)};
  const std::size_t offset = signatureOffset(set_);
  const std::vector<float> query_profile(query + n, query + n + profile_size_);
  const ProfileComparer profile_query(query_profile.data());
  std::vector<double> profile_distance(kBlock);
  double* out = scores->data();
  for (std::size_t begin = 0; begin < limit; begin += kBlock) {
    const std::size_t end = std::min(limit, begin + kBlock), width = end - begin;
    bool profile_done = false;
    for (const Stump& s : classifier.stumps()) {
      const std::size_t f = std::size_t(s.feature);
      switch (layout.kind(f)) {
        case StumpKind::kScalar:
          addScalarStump(s, n, query[f % n], columns_[f % n].data() + begin, width, out + begin);
          break;
        case StumpKind::kSignature: {
          const std::size_t g = layout.signature(f), first = offset + g * kSignatureLevels;
          const double query_magnitude = signatureMagnitude(query + first);
          for (std::size_t k = begin; k < end; ++k) {
            const double value = signatureFromSums(signatureSum(columns_, first, query + first, k), query_magnitude,
                                                   magnitudes_[g][k], layout.relative(f));
            out[k] += s.votesMatch(value) ? s.alpha : 0.0;
          }
          break;
        }
        case StumpKind::kProfile:
          if (!profile_done)
            for (std::size_t k = begin; k < end; ++k)
              profile_distance[k - begin] = profile_query.distance(profiles_.data() + k * profile_size_, profile_presence_[k], kProfileNoOverlap);
          profile_done = true;
          for (std::size_t k = begin; k < end; ++k) out[k] += s.votesMatch(profile_distance[k - begin]) ? s.alpha : 0.0;
          break;
      }
    }
    for (std::size_t k = begin; k < end; ++k) out[k] /= classifier.alphaSum();  // as StrongClassifier::score
  }
}

std::vector<LoopCandidate> KeyframeStore::query(const StrongClassifier& classifier, const double* query,
                                                std::size_t limit, std::size_t max_candidates,
                                                std::size_t threads) const {
  checkClassifier(classifier);
  limit = std::min(limit, size_);
  std::vector<LoopCandidate> candidates;
  const double alpha_sum = classifier.alphaSum();
  if (alpha_sum <= 0.0 || limit == 0 || max_candidates == 0) return candidates;
  const std::size_t n = columns_.size();
  const StumpLayout layout{n, signatureCount(set_), profilePairFeature(set_)};
  const std::size_t offset = signatureOffset(set_);
  // Cheap stumps (scalars, signatures) heaviest first, so that keyframes fall out early; the
  // costly profile stumps last, on the few keyframes still able to reach K.
  std::vector<Stump> cheap, profile;
  for (const Stump& s : classifier.stumps())
    (layout.kind(std::size_t(s.feature)) == StumpKind::kProfile ? profile : cheap).push_back(s);
  // (Ordering by alpha per unit of work instead, a signature stump costing 3 or 8 scalar
  // ones, measured slower in BM_QueryKeyframes: the heavy stumps prune more.)
  std::stable_sort(cheap.begin(), cheap.end(), [](const Stump& a, const Stump& b) { return a.alpha > b.alpha; });
  double profile_alpha = 0.0;
  for (const Stump& s : profile) profile_alpha += s.alpha;
  // Profile stumps that vote "match" below their threshold, largest threshold first: a keyframe
  // that still needs r of their alpha needs a distance below the threshold where their
  // cumulated alpha first reaches r, so the profile distance may give up at that threshold.
  // One that needs none still needs its votes, but every distance at or above the largest
  // threshold gives the same ones (all "no"), so it may give up there.
  bool profile_all_below = true;
  for (const Stump& s : profile) profile_all_below = profile_all_below && s.polarity > 0;
  std::vector<Stump> profile_by_threshold = profile;
  std::sort(profile_by_threshold.begin(), profile_by_threshold.end(),
            [](const Stump& a, const Stump& b) { return a.threshold > b.threshold; });
  const double alpha_margin = 1e-9 * alpha_sum;  // cumulated alpha in another order: stay safe
  auto rejectAbove = [&](double still_needed) {
    if (!profile_all_below || profile.empty()) return kProfileNoOverlap;
    if (still_needed <= alpha_margin) return std::min(profile_by_threshold.front().threshold, kProfileNoOverlap);
    double cumulated = 0.0;
    for (const Stump& s : profile_by_threshold) {
      cumulated += s.alpha;
      if (cumulated >= still_needed - alpha_margin) return std::min(s.threshold, kProfileNoOverlap);
    }
    return -1.0;  // cannot reach K whatever the distance (the alive test keeps none such)
  };
  std::vector<double> remaining(cheap.size() + 1, profile_alpha);  // alpha of cheap[i..] and profile
  for (std::size_t i = cheap.size(); i-- > 0;) remaining[i] = remaining[i + 1] + cheap[i].alpha;
  // A keyframe is dropped when even every stump to come cannot lift it to the bar: K, or once
  // some thread holds max_candidates scores, the lowest of them (no keyframe below it can be
  // among the best max_candidates, and a query asked for few finds many above K in a large
  // store). Threads share the highest such bar. The margin keeps a keyframe whose reordered
  // sum rounds just below the bar.
  std::atomic<double> bar{classifier.thresholdK()};
  auto neededNow = [&] { return bar.load(std::memory_order_relaxed) * alpha_sum - 1e-9 * alpha_sum; };
  auto raiseBar = [&](double score) {
    double current = bar.load(std::memory_order_relaxed);
    while (score > current && !bar.compare_exchange_weak(current, score, std::memory_order_relaxed)) {
    }
  };
  constexpr std::size_t kCheckEvery = 4;
  // Dense passes until fewer than 1 in kSparseBelow keyframes of a block is in the race: a
  // vector pass over all of them costs about what one over a few scattered ones does
  // (BM_QueryKeyframes at 1e6: 1 in 4 took 43-45 ms with 2 threads, 1 in 8 to 1 in 32 and
  // never 31-38 ms, 2026-11-28).
  constexpr std::size_t kSparseBelow = 8;

  // Each thread takes the next block not yet taken until none is left, with its own work
  // arrays: a thread slowed by the machine then simply takes fewer blocks.
  std::atomic<std::size_t> next_block{0};
  auto scanBlocks = [&](std::vector<LoopCandidate>* found) {
    const std::size_t signatures = signatureCount(set_);
    std::vector<double> partial(kBlock), distance(signatures * kBlock), query_magnitude(signatures);
    for (std::size_t g = 0; g < signatures; ++g) query_magnitude[g] = signatureMagnitude(query + offset + g * kSignatureLevels);
    std::vector<char> signature_ready(signatures);
    std::vector<std::size_t> alive;
    const std::vector<float> query_profile(query + n, query + n + profile_size_);
    const ProfileComparer profile_query(query_profile.data());
    auto denseSignature = [&](std::size_t g, std::size_t begin, std::size_t width) {
      addSignatureDistances(columns_, offset + g * kSignatureLevels, query + offset + g * kSignatureLevels, begin,
                            width, distance.data() + g * kBlock);
      signature_ready[g] = 1;
    };
    auto signatureOf = [&](std::size_t f, std::size_t begin, std::size_t k) {
      const std::size_t g = layout.signature(f);
      return signatureFromSums(distance[g * kBlock + k], query_magnitude[g], magnitudes_[g][begin + k], layout.relative(f));
    };

    std::priority_queue<double, std::vector<double>, std::greater<double>> best;  // this thread's top scores
    for (std::size_t block = next_block++; block * kBlock < limit; block = next_block++) {
      const std::size_t begin = block * kBlock, width = std::min(limit, begin + kBlock) - begin;
      const double needed = neededNow();
      std::fill(partial.begin(), partial.begin() + long(width), 0.0);
      std::fill(signature_ready.begin(), signature_ready.end(), 0);
      // Dense: every keyframe of the block, while most of them are still in the race.
      std::size_t i = 0;
      bool sparse = false, dead = false;
      while (i < cheap.size() && !sparse) {
        const Stump& s = cheap[i];
        const std::size_t f = std::size_t(s.feature);
        if (layout.kind(f) == StumpKind::kScalar) {
          addScalarStump(s, n, query[f % n], columns_[f % n].data() + begin, width, partial.data());
        } else {
          const std::size_t g = layout.signature(f);
          if (!signature_ready[g]) denseSignature(g, begin, width);
          addSignatureStump(s, layout.relative(f), distance.data() + g * kBlock, query_magnitude[g],
                            magnitudes_[g].data() + begin, width, partial.data());
        }
        ++i;
        if (i % kCheckEvery == 0 || i == cheap.size()) {
          const std::size_t in_race = countInRace(partial.data(), width, remaining[i], needed);
          dead = in_race == 0;
          sparse = dead || in_race * kSparseBelow < width || i == cheap.size();
        }
      }
      if (dead) continue;
      alive.resize(width);
      std::size_t in_race = 0;
      for (std::size_t k = 0; k < width; ++k) {
        alive[in_race] = k;
        in_race += partial[k] + remaining[i] >= needed;
      }
      alive.resize(in_race);
      // Sparse: the rest of the cheap stumps on the keyframes still in the race, one by one.
      for (; i < cheap.size() && !alive.empty(); ++i) {
        const Stump& s = cheap[i];
        const std::size_t f = std::size_t(s.feature);
        std::size_t kept = 0;
        for (std::size_t k : alive) {
          double value;
          if (layout.kind(f) == StumpKind::kScalar) {
            value = pairFeatureValue(f, n, query[f % n], double(columns_[f % n][begin + k]));
          } else if (signature_ready[layout.signature(f)]) {
            value = signatureOf(f, begin, k);
          } else {
            const std::size_t g = layout.signature(f), first = offset + g * kSignatureLevels;
            value = signatureFromSums(signatureSum(columns_, first, query + first, begin + k), query_magnitude[g],
                                      magnitudes_[g][begin + k], layout.relative(f));
          }
          partial[k] += s.votesMatch(value) ? s.alpha : 0.0;
          alive[kept] = k;  // branch-free: survival is close to a coin toss, a branch mispredicts
          kept += partial[k] + remaining[i + 1] >= needed;
        }
        alive.resize(kept);
      }
      // The profile distance, once per keyframe still in the race, for every profile stump.
      if (!profile.empty()) {
        std::size_t kept = 0;
        constexpr std::size_t kAhead = 4;  // survivors are scattered: fetch their rows early
        auto prefetchRow = [&](std::size_t k) {
          const char* row = reinterpret_cast<const char*>(profiles_.data() + (begin + k) * profile_size_);
          const std::size_t bytes = profile_size_ * sizeof(float);
          for (std::size_t byte = 0; byte < bytes; byte += 64) __builtin_prefetch(row + byte);
          __builtin_prefetch(row + bytes - 1);  // rows need not start on a cache line
        };
        for (std::size_t i = 0; i < kAhead && i < alive.size(); ++i) prefetchRow(alive[i]);
        for (std::size_t i = 0; i < alive.size(); ++i) {
          const std::size_t k = alive[i];
          if (i + kAhead < alive.size()) prefetchRow(alive[i + kAhead]);
          const double value =
              profile_query.distance(profiles_.data() + (begin + k) * profile_size_, profile_presence_[begin + k],
                                 rejectAbove(needed - partial[k]));
          for (const Stump& s : profile) partial[k] += s.votesMatch(value) ? s.alpha : 0.0;
          if (partial[k] >= needed) alive[kept++] = k;
        }
        alive.resize(kept);
      }
      for (std::size_t k : alive) {
        const double score = partial[k] / alpha_sum;
        if (score < classifier.thresholdK()) continue;
        found->push_back({begin + k, score});
        best.push(score);
        if (best.size() > max_candidates) best.pop();
        if (best.size() == max_candidates) raiseBar(best.top());
      }
    }
  };
  const std::size_t blocks = (limit + kBlock - 1) / kBlock;
  const std::size_t workers = std::max<std::size_t>(1, std::min<std::size_t>(threads, blocks));
  std::vector<std::vector<LoopCandidate>> found(workers);
  std::vector<std::thread> pool;
  for (std::size_t w = 0; w + 1 < workers; ++w) pool.emplace_back(scanBlocks, &found[w]);
  scanBlocks(&found[workers - 1]);  // this thread works too
  for (std::thread& t : pool) t.join();
  for (const auto& part : found) candidates.insert(candidates.end(), part.begin(), part.end());
  const std::size_t keep = std::min(max_candidates, candidates.size());
  std::partial_sort(candidates.begin(), candidates.begin() + long(keep), candidates.end(),
                    [](const LoopCandidate& a, const LoopCandidate& b) {
                      return a.score > b.score || (a.score == b.score && a.keyframe < b.keyframe);
                    });
  candidates.resize(keep);
  return candidates;
}

}  // namespace llc
