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
  /// Takes the values (all >= 0 or NaN-free; negative values go into the first bucket,
  /// which keeps results exact, only slower). Reuses its buffers between calls.
  void assign(const double* values, std::size_t count);
  std::size_t size() const { return values_.size(); }
  /// The value a full ascending sort puts at `rank` (< size()).
  double at(std::size_t rank);

  static constexpr std::size_t kBuckets = 512;

 private:
  std::vector<double> values_;      ///< bucket by bucket; inside a bucket in selection order
  std::vector<std::uint32_t> key_;  ///< scratch: bucket of each input value
  std::uint32_t start_[kBuckets + 1] = {};  ///< bucket b holds values_[start_[b], start_[b+1])
};

}  // namespace llc
