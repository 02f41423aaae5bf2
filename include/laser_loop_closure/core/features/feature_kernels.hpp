// The loops over the beams behind the scan features (features.hpp), each one pass with no
// branch on the data, so the compiler vectorises them (sums in an order of its choosing, hence
// equal to a plain loop's up to rounding). A closed ring's seam is left to the caller.
#pragma once

#include <cstddef>
#include <cstdint>

namespace llc {

/// Sums over the beams.
struct BeamSums {
  std::size_t valid = 0;  ///< beams with a finite return in (0, r_max)
  double x = 0.0, y = 0.0, range = 0.0;  ///< over the valid beams
  double clipped = 0.0;  ///< of the clipped ranges over every beam
};

/// valid[i] = 1 when 0 < ranges[i] < r_max (so not for NaN or infinity) and the bearing is
/// known (cosine and sine not both 0: the caller's mark of a bearing that is not finite), else 0; clipped[i] =
/// ranges[i] when valid else r_max, (x[i], y[i]) = clipped[i] * (cosines[i], sines[i]).
/// (Flags as doubles here and below: loops that mix byte and double lanes vectorise badly.)
BeamSums prepareBeams(const double* ranges, const double* cosines, const double* sines, std::size_t n, double r_max,
                      double* valid, double* clipped, double* x, double* y);

/// Sums over the neighbour pairs (i, i + 1) for i + 1 < n.
struct NeighbourSums {
  double area = 0.0;            ///< of clipped[i] * clipped[i+1] * half_sines[i]
  double far_distance = 0.0;    ///< of steps[i]
  double distance = 0.0;        ///< of the segments (pairs of valid points)
  double close_distance = 0.0;  ///< of the segments shorter than the gate
  std::size_t segments = 0;
};

/// Also writes segments[i] = steps[i] where points i and i + 1 are both valid, else -1; leaves
/// segments[n - 1] alone.
NeighbourSums sumNeighbours(const double* clipped, const double* half_sines, const double* steps, const double* valid,
                            std::size_t n, double gate, double* segments);

/// Sum of (values[i] - mean)^2 over the i < n with values[i] >= 0.
double sumSquaredDeviations(const double* values, std::size_t n, double mean);

/// Sums over the triples (a, a + 1, a + 2) whose two segments are both longer than zero.
struct TripleSums {
  double turn = 0.0;       ///< of turns[a]
  double curvature = 0.0;  ///< of the curvatures, over the triples whose ends are apart too
  std::size_t curved = 0;  ///< those triples
};

/// The curvature of a triple is 4 * its area / the product of its sides = 2 |u x v| / (|u| |v| |w|),
/// with u, v its segments and w = skips[a] the distance between its ends. Writes it to
/// curvatures[a] for a + 2 < n, -1 where it is not defined.
TripleSums sumTriples(const double* x, const double* y, const double* segments, const double* skips,
                      const double* turns, std::size_t n, double* curvatures);

/// The curvature of one triple as sumTriples defines it, or -1 (for a closed ring's seam).
double tripleCurvature(double ax, double ay, double bx, double by, double cx, double cy, double segment_ab,
                       double segment_bc, double skip_ac);

/// Second moments of the valid points about (cx, cy), and the sums the circle fit needs.
struct MomentSums {
  double uu = 0.0, vv = 0.0, uv = 0.0, uuu = 0.0, vvv = 0.0, uvv = 0.0, vuu = 0.0;
  double distance = 0.0;         ///< of centre_distances over the valid points
  double range_deviation = 0.0;  ///< of (clipped - mean_range)^2 over the valid points
  double squared_range = 0.0;    ///< of clipped^2 over the valid points
};

MomentSums sumMoments(const double* x, const double* y, const double* clipped, const double* centre_distances,
                      const double* valid, std::size_t n, double cx, double cy, double mean_range);

/// Over the valid points: sum of (centre_distances - mean)^2, and when circle_distances is not
/// null, sum of (radius - circle_distances)^2.
void sumDeviations(const double* centre_distances, const double* circle_distances, const double* valid,
                   std::size_t n, double mean, double radius, double* deviation_sum, double* residual_sum);

/// Runs of set flags in a cyclic (closed) or open sequence: writes the first and last index of
/// each to first and last (room for n + 1 each), the run through a closed sequence's seam
/// starting at its first index and ending past the seam, and returns their number. A closed
/// sequence that is all set gives no run (the caller decides what that means).
/// links: when not null, a run also breaks after each i whose links[i] is 0.
std::size_t findRuns(const std::uint8_t* flags, const std::uint8_t* links, std::size_t n, bool closed,
                     std::uint32_t* first, std::uint32_t* last);

}  // namespace llc
