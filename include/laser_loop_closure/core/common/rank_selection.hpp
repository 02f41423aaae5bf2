// Exact order statistics of many ranks of one array of non-negative numbers, faster than
// repeated std::nth_element: one counting pass sorts the values into buckets by the leading
// bits of their float form (a monotone key), then each requested rank is selected inside its
// own small bucket. The value returned for rank r is exactly what a full sort puts at r.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace llc {

class RankSelector {
 public:
  /// What the values are, for the span of the buckets (values outside it stay exact, only slower).
  enum class Scale {
    kDistances,         ///< 16 octaves from 2^-8 to 2^8, 32 buckets per octave (metres: 4 mm .. 256 m)
    kSquaredDistances,  ///< 32 octaves from 2^-16 to 2^16, 16 buckets per octave (the same, squared)
  };

  /// Takes the values (all >= 0 or NaN-free; negative values go into the first bucket,
  /// which keeps results exact, only slower). Reuses its buffers between calls.
  void assign(const double* values, std::size_t count, Scale scale = Scale::kDistances);
  std::size_t size() const { return values_.size(); }
  /// The value a full ascending sort puts at `rank` (< size()).
  double at(std::size_t rank);

  static constexpr std::size_t kBuckets = 512;
  /// Below this many values one histogram lane is used instead of four.
  static constexpr std::size_t kFewValues = 1024;

 private:
  std::vector<double> values_;      ///< bucket by bucket; inside a bucket in selection order
  std::vector<std::uint16_t> key_;  ///< scratch: bucket of each input value
  std::uint32_t start_[kBuckets + 1] = {};  ///< bucket b holds values_[start_[b], start_[b+1])
};

}  // namespace llc
