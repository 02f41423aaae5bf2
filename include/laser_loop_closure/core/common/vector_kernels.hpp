// Small loops over point arrays, written so the compiler vectorises them (no reductions, no
// branches); each has an AVX2 twin that the loader picks on CPUs that have it. Every value is
// computed with the same operations in the same order as the plain formula, so results are
// bit-identical to a scalar loop (sqrt is correctly rounded in every lane).
#pragma once

#include <cstddef>

/// Marks a function that gets an AVX2 twin, picked by the loader on CPUs that have it.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define LLC_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define LLC_VECTOR_CLONES
#endif

namespace llc {

/// out[i] = |p[i + separation] - p[i]| = sqrt((x[i+s] - x[i])^2 + (y[i+s] - y[i])^2) for
/// i + separation < count; out needs count - separation values (nothing when that is <= 0).
void distancesAhead(const double* x, const double* y, std::size_t count, std::size_t separation, double* out);

/// The same without the square root: out[i] = (x[i+s] - x[i])^2 + (y[i+s] - y[i])^2, the very
/// value distancesAhead takes the root of (so the root of a selected one is bit for bit its distance).
void squaredDistancesAhead(const double* x, const double* y, std::size_t count, std::size_t separation, double* out);

/// out[i] = sqrt(((x[i] - cx) - dx)^2 + ((y[i] - cy) - dy)^2) for i < count: the distance to
/// (cx + dx, cy + dy) with the centred coordinates (x - cx, y - cy) of the moment sums.
void distancesFromCentred(const double* x, const double* y, std::size_t count, double cx, double cy, double dx,
                          double dy, double* out);

/// The angle in [0, pi] between the vectors u and v: atan2(|u x v|, u . v), which equals
/// acos(u . v / (|u| |v|)) but stays accurate for nearly parallel vectors; 0 when either is zero.
/// Branch-free (Cephes' rational atan on [0, 0.66] after range reduction) so loops of it
/// vectorise; within a few units in the last place of std::atan2 (a test checks).
inline double angleBetween(double ux, double uy, double vx, double vy) {
  const double cross = ux * vy - uy * vx, dot = ux * vx + uy * vy;
  const double y = cross < 0.0 ? -cross : cross, x = dot < 0.0 ? -dot : dot;
  const bool steep = y > x;
  const double big = steep ? y : x, small = steep ? x : y;
  const double t = big > 0.0 ? small / big : 0.0;  // tan of the reduced angle, in [0, 1]
  // atan(t) for t in [0, 1]: above 0.66 by atan(t) = pi/4 + atan((t - 1) / (t + 1)).
  const bool upper = t > 0.66;
  const double w = upper ? (t - 1.0) / (t + 1.0) : t;
  const double z = w * w;
  const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
                    1.228866684490136173410e2) * z - 6.485021904942025371773e1;
  const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z +
                    4.853903996359136964868e2) * z + 1.945506571482613964425e2;
  constexpr double kQuarterPi = 0.78539816339744830962, kMoreBits = 6.123233995736765886130e-17;
  const double reduced = (upper ? kQuarterPi + 0.5 * kMoreBits : 0.0) + (w * (z * p / q) + w);
  const double first_octant = steep ? 2.0 * kQuarterPi + kMoreBits - reduced : reduced;  // angle from the dot axis
  return dot < 0.0 ? 4.0 * kQuarterPi + 2.0 * kMoreBits - first_octant : first_octant;
}

/// out[a] = angleBetween(p[a+1] - p[a], p[a+2] - p[a+1]) for a + 2 < count: the turn at each
/// interior point of the chain.
void turnAngles(const double* x, const double* y, std::size_t count, double* out);

}  // namespace llc
