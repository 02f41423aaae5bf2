// Seeded random numbers whose sequence is the same on every platform (std::mt19937_64 is
// fully specified; the std distributions are not, so they are not used).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace llc {

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}

  /// Uniform integer in [0, n), n > 0, without modulo bias.
  std::uint64_t index(std::uint64_t n) {
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;
    std::uint64_t value;
    do value = engine_(); while (value >= limit);
    return value % n;
  }
  /// Uniform real in [0, 1).
  double uniform() { return double(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Normal deviate (Box-Muller, one of the pair).
  double normal(double mean, double sigma) {
    const double u = 1.0 - uniform();  // (0, 1]
    return mean + sigma * std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * M_PI * uniform());
  }

  template <typename T>
  void shuffle(std::vector<T>& values) {  // Fisher-Yates
    for (std::size_t i = values.size(); i > 1; --i) std::swap(values[i - 1], values[index(i)]);
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace llc
