#include "laser_loop_closure/core/range_profile.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
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
double profileDistance(const float* a, const float* b, double stop_below) {
  constexpr std::size_t n = kProfileSectors;
  constexpr float empty = float(kProfileEmpty);
  // Eight lanes (GCC/Clang vector extension: one AVX register, or two SSE/NEON ones): lane l
  // sums the sectors s = l mod 8, a fixed order of additions, so every caller and every CPU
  // gets the same bits. a is padded with empty sectors to a multiple of 8; b is doubled, so
  // every rotation is a contiguous window; masks replace tests.
  typedef float Lanes __attribute__((vector_size(32)));
  typedef int Bits __attribute__((vector_size(32)));
  constexpr std::size_t padded = (n + 7) / 8 * 8;
  alignas(32) float ma[padded] = {}, va[padded] = {}, mb[n + padded] = {}, vb[n + padded] = {};
  std::size_t count_a = 0, count_b = 0;
  for (std::size_t s = 0; s < n; ++s) {
    const bool has_a = a[s] != empty, has_b = b[s] != empty;
    ma[s] = has_a ? 1.0f : 0.0f;
    va[s] = has_a ? a[s] : 0.0f;
    mb[s] = has_b ? 1.0f : 0.0f;
    vb[s] = has_b ? b[s] : 0.0f;
    count_a += has_a;
    count_b += has_b;
  }
  for (std::size_t s = n; s < n + padded && s < 2 * n; ++s) mb[s] = mb[s - n], vb[s] = vb[s - n];
  const float needed = std::max(1.0f, std::ceil(float(kProfileMinOverlap) * float(std::min(count_a, count_b))));
  const Bits magnitude = ~(Bits)(Lanes{-0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f, -0.0f});
  double best = kProfileNoOverlap;
  for (std::size_t shift = 0; shift < n; ++shift) {
    Lanes sum = {}, overlap = {};
    for (std::size_t s = 0; s < padded; s += 8) {
      Lanes xa, xm, ya, ym;
      std::memcpy(&xa, va + s, sizeof xa);
      std::memcpy(&xm, ma + s, sizeof xm);
      std::memcpy(&ya, vb + s + shift, sizeof ya);
      std::memcpy(&ym, mb + s + shift, sizeof ym);
      const Lanes m = xm * ym;
      const Lanes difference = (Lanes)((Bits)(xa - ya) & magnitude);  // |x| by clearing the sign bit
      sum += m * difference;
      overlap += m;
    }
    const float total = ((sum[0] + sum[1]) + (sum[2] + sum[3])) + ((sum[4] + sum[5]) + (sum[6] + sum[7]));
    const float shared =
        ((overlap[0] + overlap[1]) + (overlap[2] + overlap[3])) + ((overlap[4] + overlap[5]) + (overlap[6] + overlap[7]));
    if (shared >= needed) best = std::min(best, double(total) / double(shared));
    if (best < stop_below) break;
  }
  return best;
}

}  // namespace llc
