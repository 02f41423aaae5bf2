#include "laser_loop_closure/core/range_profile.hpp"

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
  return profileDistance(fa, fb, -1.0);
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))  // an AVX2 twin, picked on CPUs that have it
#endif
double profileDistance(const float* a, const float* b, double stop_below, double reject_at_or_above) {
  constexpr std::size_t n = kProfileSectors;
  constexpr float empty = float(kProfileEmpty);
  static_assert(kProfileSectors < 64, "sector masks are 64-bit words");
  // Eight lanes (GCC/Clang vector extension: one AVX register, or two SSE/NEON ones): lane l
  // sums the sectors s = l mod 8, a fixed order of additions, so every caller and every CPU
  // gets the same bits. a is padded with empty sectors to a multiple of 8; b is doubled, so
  // every rotation is a contiguous window; masks replace tests.
  typedef float Lanes __attribute__((vector_size(32)));
  typedef int Bits __attribute__((vector_size(32)));
  constexpr std::size_t padded = (n + 7) / 8 * 8;
  // Filled element by element: zero-initialising these small arrays (rep stos) cost more
  // than the arithmetic below.
  alignas(32) float ma[padded], va[padded], mb[n + padded], vb[n + padded];
  std::uint64_t bits_a = 0, bits_b = 0;  // sector s present: bit s
  for (std::size_t s = 0; s < n; ++s) {
    const bool has_a = a[s] != empty, has_b = b[s] != empty;
    ma[s] = has_a ? 1.0f : 0.0f;
    va[s] = has_a ? a[s] : 0.0f;
    mb[s] = has_b ? 1.0f : 0.0f;
    vb[s] = has_b ? b[s] : 0.0f;
    bits_a |= std::uint64_t(has_a) << s;
    bits_b |= std::uint64_t(has_b) << s;
  }
  for (std::size_t s = n; s < padded; ++s) ma[s] = 0.0f, va[s] = 0.0f;
  for (std::size_t s = n; s < n + padded; ++s) {
    mb[s] = s < 2 * n ? mb[s - n] : 0.0f;
    vb[s] = s < 2 * n ? vb[s - n] : 0.0f;
  }
  const int count_a = __builtin_popcountll(bits_a), count_b = __builtin_popcountll(bits_b);
  const int needed = std::max(1, int(std::ceil(float(kProfileMinOverlap) * float(std::min(count_a, count_b)))));
  const std::uint64_t all = (std::uint64_t(1) << n) - 1;
  const Bits magnitude = ~(Bits)(Lanes{-0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f});
  auto reduce = [](const Lanes& v) { return ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7])); };
  double best = kProfileNoOverlap;
  for (std::size_t shift = 0; shift < n; ++shift) {
    // Sectors shared at this rotation (sector j of a against sector j + shift of b), counted
    // from the masks first: a rotation without enough overlap costs no arithmetic.
    const std::uint64_t rotated = shift == 0 ? bits_b : ((bits_b >> shift) | (bits_b << (n - shift))) & all;
    const int shared = __builtin_popcountll(bits_a & rotated);
    if (shared < needed) continue;
    // Sums of non-negative terms only grow (rounding is monotone), so a partial sum already at
    // the limit proves this rotation cannot go below min(best, reject_at_or_above).
    // Rounded up: float() of a value 2^-22 larger is still at least the bound.
    const float limit = float(std::min(best, reject_at_or_above) * double(shared) * (1.0 + 0x1p-22));
    Lanes sum = {};
    bool beaten = false;
    for (std::size_t s = 0; s < padded; s += 8) {
      Lanes xa, xm, ya, ym;
      std::memcpy(&xa, va + s, sizeof xa);
      std::memcpy(&xm, ma + s, sizeof xm);
      std::memcpy(&ya, vb + s + shift, sizeof ya);
      std::memcpy(&ym, mb + s + shift, sizeof ym);
      const Lanes difference = (Lanes)((Bits)(xa - ya) & magnitude);  // |x| by clearing the sign bit
      sum += (xm * ym) * difference;
      if (s == 16 && reduce(sum) >= limit) {
        beaten = true;
        break;
      }
    }
    if (beaten) continue;
    best = std::min(best, double(reduce(sum)) / double(shared));
    if (best < stop_below) break;
  }
  return best;
}

}  // namespace llc
