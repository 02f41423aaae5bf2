#include "laser_loop_closure/core/features/feature_kernels.hpp"

#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/common/vector_kernels.hpp"

namespace llc {

LLC_VECTOR_CLONES
BeamSums prepareBeams(const double* ranges, const double* cosines, const double* sines, std::size_t n, double r_max,
                      double* valid, double* clipped, double* x, double* y) {
  std::size_t count = 0;
  double sum_x = 0.0, sum_y = 0.0, sum_range = 0.0, sum_clipped = 0.0;
#pragma omp simd reduction(+ : count, sum_x, sum_y, sum_range, sum_clipped)
  for (std::size_t i = 0; i < n; ++i) {
    const double r = ranges[i];
    const bool ok = r > 0.0 && r < r_max && (cosines[i] != 0.0 || sines[i] != 0.0);
    const double c = ok ? r : r_max;
    const double px = c * cosines[i], py = c * sines[i];
    valid[i] = ok ? 1.0 : 0.0;
    clipped[i] = c;
    x[i] = px;
    y[i] = py;
    count += ok ? 1 : 0;
    sum_x += ok ? px : 0.0;
    sum_y += ok ? py : 0.0;
    sum_range += ok ? r : 0.0;
    sum_clipped += c;
  }
  return {count, sum_x, sum_y, sum_range, sum_clipped};
}

LLC_VECTOR_CLONES
NeighbourSums sumNeighbours(const double* clipped, const double* half_sines, const double* steps, const double* valid,
                            std::size_t n, double gate, double* segments) {
  double area = 0.0, far_distance = 0.0, distance = 0.0, close_distance = 0.0;
  std::size_t count = 0;
  const std::size_t pairs = n > 0 ? n - 1 : 0;
#pragma omp simd reduction(+ : area, far_distance, distance, close_distance, count)
  for (std::size_t i = 0; i < pairs; ++i) {
    const double d = steps[i];
    const bool both = valid[i] * valid[i + 1] != 0.0;
    area += clipped[i] * clipped[i + 1] * half_sines[i];
    far_distance += d;
    segments[i] = both ? d : -1.0;
    distance += both ? d : 0.0;
    close_distance += both && d < gate ? d : 0.0;
    count += both ? 1 : 0;
  }
  return {area, far_distance, distance, close_distance, count};
}

LLC_VECTOR_CLONES
double sumSquaredDeviations(const double* values, std::size_t n, double mean) {
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (std::size_t i = 0; i < n; ++i) {
    const double d = values[i] - mean;
    sum += values[i] >= 0.0 ? d * d : 0.0;
  }
  return sum;
}

double tripleCurvature(double ax, double ay, double bx, double by, double cx, double cy, double segment_ab,
                       double segment_bc, double skip_ac) {
  const double cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx);
  const bool defined = segment_ab > 0.0 && segment_bc > 0.0 && skip_ac > 0.0;
  // The division is done whatever the triple (so the loop has no branch); its result is kept
  // only when defined.
  const double k = 2.0 * std::abs(cross) / (segment_ab * segment_bc * skip_ac);
  return defined ? k : -1.0;
}

LLC_VECTOR_CLONES
TripleSums sumTriples(const double* x, const double* y, const double* segments, const double* skips,
                      const double* turns, std::size_t n, double* curvatures) {
  double turn = 0.0, curvature = 0.0;
  std::size_t curved = 0;
  const std::size_t triples = n > 2 ? n - 2 : 0;
#pragma omp simd reduction(+ : turn, curvature, curved)
  for (std::size_t a = 0; a < triples; ++a) {
    const bool joined = segments[a] > 0.0 && segments[a + 1] > 0.0;
    const double k = tripleCurvature(x[a], y[a], x[a + 1], y[a + 1], x[a + 2], y[a + 2], segments[a], segments[a + 1],
                                     skips[a]);
    curvatures[a] = k;
    turn += joined ? turns[a] : 0.0;
    curvature += k >= 0.0 ? k : 0.0;
    curved += k >= 0.0 ? 1 : 0;
  }
  return {turn, curvature, curved};
}

LLC_VECTOR_CLONES
MomentSums sumMoments(const double* x, const double* y, const double* clipped, const double* centre_distances,
                      const double* valid, std::size_t n, double cx, double cy, double mean_range) {
  double uu = 0.0, vv = 0.0, uv = 0.0, uuu = 0.0, vvv = 0.0, uvv = 0.0, vuu = 0.0;
  double distance = 0.0, range_deviation = 0.0, squared_range = 0.0;
#pragma omp simd reduction(+ : uu, vv, uv, uuu, vvv, uvv, vuu, distance, range_deviation, squared_range)
  for (std::size_t i = 0; i < n; ++i) {
    const bool ok = valid[i] != 0.0;
    const double u = ok ? x[i] - cx : 0.0, v = ok ? y[i] - cy : 0.0;
    const double c = ok ? clipped[i] : 0.0, dr = ok ? clipped[i] - mean_range : 0.0;
    uu += u * u;
    vv += v * v;
    uv += u * v;
    uuu += u * u * u;
    vvv += v * v * v;
    uvv += u * v * v;
    vuu += v * u * u;
    distance += ok ? centre_distances[i] : 0.0;
    range_deviation += dr * dr;
    squared_range += c * c;
  }
  return {uu, vv, uv, uuu, vvv, uvv, vuu, distance, range_deviation, squared_range};
}

LLC_VECTOR_CLONES
void sumDeviations(const double* centre_distances, const double* circle_distances, const double* valid,
                   std::size_t n, double mean, double radius, double* deviation_sum, double* residual_sum) {
  double deviation = 0.0, residual = 0.0;
  if (circle_distances != nullptr) {
#pragma omp simd reduction(+ : deviation, residual)
    for (std::size_t i = 0; i < n; ++i) {
      const double d = valid[i] != 0.0 ? centre_distances[i] - mean : 0.0;
      const double e = valid[i] != 0.0 ? radius - circle_distances[i] : 0.0;
      deviation += d * d;
      residual += e * e;
    }
  } else {
#pragma omp simd reduction(+ : deviation)
    for (std::size_t i = 0; i < n; ++i) {
      const double d = valid[i] != 0.0 ? centre_distances[i] - mean : 0.0;
      deviation += d * d;
    }
  }
  *deviation_sum = deviation;
  *residual_sum = residual;
}

std::size_t findRuns(const std::uint8_t* flags, const std::uint8_t* links, std::size_t n, bool closed,
                     std::uint32_t* first, std::uint32_t* last) {
  if (n == 0) return 0;
  // continues(i): the run goes on from i to i + 1 (to 0 from n - 1 on a closed sequence).
  auto continues = [&](std::size_t i) {
    const std::size_t j = i + 1 == n ? 0 : i + 1;
    if (j == 0 && !closed) return false;
    return flags[i] && flags[j] && (links == nullptr || links[i]);
  };
  // Branch-free compaction: each index is written, and kept when it starts (ends) a run.
  std::size_t starts = 0, ends = 0;
  bool before = continues(n - 1);  // whether the previous index continues into this one
  for (std::size_t i = 0; i < n; ++i) {
    const bool on = continues(i);
    first[starts] = std::uint32_t(i);
    starts += flags[i] && !before;
    last[ends] = std::uint32_t(i);
    ends += flags[i] && !on;
    before = on;
  }
  // A closed sequence's run through the seam ends before the first start: pair it with the last.
  if (ends > 0 && last[0] < first[0]) std::rotate(last, last + 1, last + ends);
  return starts;
}

}  // namespace llc
