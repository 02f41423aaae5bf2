#include "laser_loop_closure/core/common/rank_selection.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace llc {
namespace {

/// Bucket of a value: the exponent and the leading mantissa bits of its float form, counted
/// from the first bucket's float bits `kFirst` (everything smaller, zero and negatives in
/// bucket 0; everything beyond the span in the last bucket). Rounding to float is monotone, so
/// the key never orders two values wrongly.
template <unsigned kShift, std::uint32_t kFirst>
void writeKeys(const double* values, std::size_t count, std::uint16_t* keys) {
  for (std::size_t i = 0; i < count; ++i) {
    const float f = values[i] > 0.0 ? float(values[i]) : 0.0f;
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    const std::uint32_t key = bits >> kShift;
    keys[i] = std::uint16_t(key <= kFirst ? 0u : std::min<std::uint32_t>(key - kFirst, RankSelector::kBuckets - 1));
  }
}

}  // namespace

void RankSelector::assign(const double* values, std::size_t count, Scale scale) {
  key_.resize(count);
  if (scale == Scale::kDistances) writeKeys<18, (127u - 8u) << 5>(values, count, key_.data());  // 5 mantissa bits
  else writeKeys<19, (127u - 16u) << 4>(values, count, key_.data());                           // 4 mantissa bits
  values_.resize(count);
  if (count < kFewValues) {
    // Few values: one histogram and one scatter; four lanes' set-up would cost more than it saves.
    std::uint32_t next[kBuckets] = {};
    for (std::size_t i = 0; i < count; ++i) ++next[key_[i]];
    start_[0] = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) {
      start_[b + 1] = start_[b] + next[b];
      next[b] = start_[b];
    }
    for (std::size_t i = 0; i < count; ++i) values_[next[key_[i]]++] = values[i];
    return;
  }
  // Four interleaved histograms: runs of equal keys (a wall at one distance) would otherwise
  // chain every increment on the one before through memory.
  std::uint32_t partial[4][kBuckets] = {};
  std::size_t i = 0;
  for (; i + 4 <= count; i += 4) {
    ++partial[0][key_[i]];
    ++partial[1][key_[i + 1]];
    ++partial[2][key_[i + 2]];
    ++partial[3][key_[i + 3]];
  }
  for (; i < count; ++i) ++partial[0][key_[i]];
  // Bucket starts, and the same four-way split for the scatter: lane j writes after lanes < j.
  start_[0] = 0;
  std::uint32_t next[4][kBuckets];
  for (std::size_t b = 0; b < kBuckets; ++b) {
    next[0][b] = start_[b];
    next[1][b] = next[0][b] + partial[0][b];
    next[2][b] = next[1][b] + partial[1][b];
    next[3][b] = next[2][b] + partial[2][b];
    start_[b + 1] = next[3][b] + partial[3][b];
  }
  std::size_t k = 0;
  for (; k + 4 <= count; k += 4) {
    values_[next[0][key_[k]]++] = values[k];
    values_[next[1][key_[k + 1]]++] = values[k + 1];
    values_[next[2][key_[k + 2]]++] = values[k + 2];
    values_[next[3][key_[k + 3]]++] = values[k + 3];
  }
  for (; k < count; ++k) values_[next[0][key_[k]]++] = values[k];
}

double RankSelector::at(std::size_t rank) {
  if (rank >= values_.size()) throw std::out_of_range("RankSelector::at: rank beyond the values");
  // The bucket holding the rank: the last start at or before it.
  const std::uint32_t* bucket = std::upper_bound(start_, start_ + kBuckets + 1, std::uint32_t(rank)) - 1;
  auto first = values_.begin() + long(*bucket), last = values_.begin() + long(bucket[1]);
  auto wanted = values_.begin() + long(rank);
  std::nth_element(first, wanted, last);
  return *wanted;
}

}  // namespace llc
