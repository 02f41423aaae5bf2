#include "laser_loop_closure/core/features/range_profile.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace llc {

std::size_t profileSector(double bearing) {
  if (!std::isfinite(bearing)) return kProfileSectors;
  double b = std::fmod(bearing + M_PI, 2.0 * M_PI);
  if (b < 0.0) b += 2.0 * M_PI;
  return std::min(kProfileSectors - 1, std::size_t(b * (double(kProfileSectors) / (2.0 * M_PI))));
}

void writeRangeProfile(const double* bearings, const double* clipped_ranges, std::size_t beams, double* out) {
  std::vector<std::size_t> sectors(beams);
  for (std::size_t i = 0; i < beams; ++i) sectors[i] = profileSector(bearings[i]);
  writeRangeProfileBySector(sectors.data(), clipped_ranges, beams, out);
}

void writeRangeProfileBySector(const std::size_t* sectors, const double* clipped_ranges, std::size_t beams, double* out) {
  // The sum of logs as the log of a product, one logarithm per sector instead of per beam;
  // the product is folded into the sum before it could leave double range.
  double product[kProfileSectors + 1], log_sum[kProfileSectors + 1] = {};
  int count[kProfileSectors + 1] = {};
  std::fill(product, product + kProfileSectors + 1, 1.0);
  for (std::size_t i = 0; i < beams; ++i) {
    const std::size_t s = sectors[i];  // kProfileSectors: no sector, collected and ignored
    product[s] *= std::max(clipped_ranges[i], kProfileMinRange);
    ++count[s];
    if (!(product[s] < 1e150 && product[s] > 1e-150)) {  // also catches an infinite range
      log_sum[s] += std::log(product[s]);
      product[s] = 1.0;
    }
  }
  // A sector whose beams are on average nearer than kProfileNearRange is taken as hidden by
  // something close (a person, a door frame), which says little about the place: empty.
  const double near = std::log(kProfileNearRange);
  for (std::size_t s = 0; s < kProfileSectors; ++s) {
    const double mean = count[s] > 0 ? (log_sum[s] + std::log(product[s])) / count[s] : 0.0;
    out[s] = count[s] > 0 && mean >= near ? mean : kProfileEmpty;
  }
}

double profileDistance(const double* a, const double* b) {
  float fa[kProfileSectors], fb[kProfileSectors];
  for (std::size_t s = 0; s < kProfileSectors; ++s) fa[s] = float(a[s]), fb[s] = float(b[s]);
  return profileDistance(fa, fb);
}

double profileDistance(const float* a, const float* b, double reject_at_or_above) {
  return ProfileComparer(a).distance(b, reject_at_or_above);
}

std::uint64_t profilePresence(const float* profile) {
  static_assert(kProfileSectors < 64, "sector masks are 64-bit words");
  std::uint64_t bits = 0;
  for (std::size_t s = 0; s < kProfileSectors; ++s) bits |= std::uint64_t(profile[s] != float(kProfileEmpty)) << s;
  return bits;
}

ProfileComparer::ProfileComparer(const float* a) {
  constexpr std::size_t n = kProfileSectors;
  const float empty = float(kProfileEmpty);
  bits_ = profilePresence(a);
  count_ = __builtin_popcountll(bits_);
  const std::uint64_t all = (std::uint64_t(1) << n) - 1;
  for (std::size_t t = 0; t < 8 * kGroups; ++t)  // bit j of rotation t: sector j - t of a present
    rotated_[t] = t >= n ? 0 : t == 0 ? bits_ : ((bits_ << t) | (bits_ >> (n - t))) & all;
  for (std::size_t m = 0; m < kWindow; ++m) {
    const std::size_t s = (n - 1 + n * 3 - m) % n;  // (n - 1 - m) mod n, m < 3n
    const bool present = a[s] != empty;
    values_[m] = present ? a[s] : 0.0f;
    present_[m] = present ? 1.0f : 0.0f;
  }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))  // an AVX2 twin, picked on CPUs that have it
#endif
double ProfileComparer::distance(const float* b, std::uint64_t bits_b, double reject_at_or_above) const {
  constexpr std::size_t n = kProfileSectors;
  // Eight rotations per lane group (GCC/Clang vector extension: one AVX register, or two
  // SSE/NEON ones); lane l of group g is rotation t = 8g + l and sums over b's sectors in
  // ascending order, so every caller and every CPU gets the same bits.
  typedef float Lanes __attribute__((vector_size(32)));
  typedef int Bits __attribute__((vector_size(32)));
  const int needed = std::max(1, int(std::ceil(float(kProfileMinOverlap) * float(std::min(count_, __builtin_popcountll(bits_b))))));
  const bool prune = reject_at_or_above < kProfileNoOverlap;  // else every rotation is summed
  // Per rotation: sectors shared (as a double: the divisor), whether it leaves enough overlap,
  // and the float sum at or above which it cannot come under reject_at_or_above (rounded up by
  // 2^-22: float() of a larger value is still at least the bound); a rotation without enough
  // overlap gets -inf, so it never counts as alive.
  alignas(32) double shared[8 * kGroups];
  alignas(32) float limit[8 * kGroups];
  unsigned live = 0;  // bit g: some rotation of group g may still matter
  for (std::size_t t = 0; t < 8 * kGroups; ++t) {
    const int common = __builtin_popcountll(rotated_[t] & bits_b);
    const bool valid = common >= needed;
    shared[t] = valid ? double(common) : 0.0;
    live |= unsigned(valid) << (t / 8);
  }
  const float bound = prune ? 1.0f : std::numeric_limits<float>::infinity();
  for (std::size_t t = 0; t < 8 * kGroups; ++t)
    limit[t] = shared[t] == 0.0 ? -std::numeric_limits<float>::infinity()
                                : bound * float(reject_at_or_above * shared[t] * (1.0 + 0x1p-22));
  const Bits magnitude = ~(Bits)(Lanes{-0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f});
  Lanes sum[kGroups];
  for (Lanes& group : sum) group = Lanes{};
  auto stillAlive = [&](std::size_t g) {
    Lanes limits;
    std::memcpy(&limits, limit + 8 * g, sizeof limits);
    // Any lane below its limit: OR of the compare masks, folded by halves.
    Bits any = sum[g] < limits;
    any |= __builtin_shufflevector(any, any, 4, 5, 6, 7, 0, 1, 2, 3);
    any |= __builtin_shufflevector(any, any, 2, 3, 0, 1, 6, 7, 4, 5);
    any |= __builtin_shufflevector(any, any, 1, 0, 3, 2, 5, 4, 7, 6);
    return any[0] != 0;
  };
  for (std::size_t j = 0; j < n && live != 0; ++j) {
    // Sums of non-negative terms only grow (rounding is monotone): a group whose every
    // rotation is already at its limit cannot give a distance below reject_at_or_above.
    if (prune && j % 12 == 0 && j > 0)
      for (std::size_t g = 0; g < kGroups; ++g)
        if ((live >> g & 1) != 0 && !stillAlive(g)) live &= ~(1u << g);
    if ((bits_b >> j & 1) == 0) continue;
    const float v = b[j];
    const Lanes bv = {v, v, v, v, v, v, v, v};
    const float* window = values_ + (n - 1 - j);
    const float* present = present_ + (n - 1 - j);
    for (std::size_t g = 0; g < kGroups; ++g) {
      if ((live >> g & 1) == 0) continue;
      Lanes av, ap;
      std::memcpy(&av, window + 8 * g, sizeof av);
      std::memcpy(&ap, present + 8 * g, sizeof ap);
      sum[g] += ap * (Lanes)((Bits)(av - bv) & magnitude);  // |a - b| where a is present, else 0
    }
  }
  // The smallest mean over the rotations still alive: four divisions per vector, the same
  // correctly rounded quotients a scalar loop forms; a rotation that does not count gets
  // kProfileNoOverlap.
  typedef double Quad __attribute__((vector_size(32)));
  typedef long long QuadBits __attribute__((vector_size(32)));
  alignas(32) float sums[8 * kGroups];
  std::memcpy(sums, sum, sizeof sums);
  const Quad none = {kProfileNoOverlap, kProfileNoOverlap, kProfileNoOverlap, kProfileNoOverlap};
  Quad lowest = none;
  for (std::size_t t = 0; t < 8 * kGroups; t += 4) {
    if ((live >> (t / 8) & 1) == 0) continue;
    Quad divisor;
    std::memcpy(&divisor, shared + t, sizeof divisor);
    const QuadBits counts = divisor > 0.0;
    const Quad total = {double(sums[t]), double(sums[t + 1]), double(sums[t + 2]), double(sums[t + 3])};
    const Quad mean = counts ? total / (counts ? divisor : none) : none;
    lowest = mean < lowest ? mean : lowest;
  }
  double best = kProfileNoOverlap;
  for (int l = 0; l < 4; ++l) best = lowest[l] < best ? lowest[l] : best;
  return best;
}

}  // namespace llc
