#include "laser_loop_closure/core/common/vector_kernels.hpp"

#include <cmath>

namespace llc {

namespace {
/// The loop of both kernels below; inlined into each of their clones, so each is vectorised
/// for its own target. The squared value is the same expression either way.
template <bool kRoot>
__attribute__((always_inline)) inline void differencesAhead(const double* x, const double* y, std::size_t count,
                                                            std::size_t separation, double* out) {
  if (separation >= count) return;
  const std::size_t m = count - separation;
  const double* x2 = x + separation;
  const double* y2 = y + separation;
  for (std::size_t i = 0; i < m; ++i) {
    const double ddx = x2[i] - x[i], ddy = y2[i] - y[i];
    out[i] = kRoot ? std::sqrt(ddx * ddx + ddy * ddy) : ddx * ddx + ddy * ddy;
  }
}
}  // namespace

LLC_VECTOR_CLONES
void distancesAhead(const double* x, const double* y, std::size_t count, std::size_t separation, double* out) {
  differencesAhead<true>(x, y, count, separation, out);
}

LLC_VECTOR_CLONES
void squaredDistancesAhead(const double* x, const double* y, std::size_t count, std::size_t separation, double* out) {
  differencesAhead<false>(x, y, count, separation, out);
}

LLC_VECTOR_CLONES
void distancesFromCentred(const double* x, const double* y, std::size_t count, double cx, double cy, double dx,
                          double dy, double* out) {
  for (std::size_t i = 0; i < count; ++i) {
    const double u = (x[i] - cx) - dx, v = (y[i] - cy) - dy;
    out[i] = std::sqrt(u * u + v * v);
  }
}

LLC_VECTOR_CLONES
void turnAngles(const double* x, const double* y, std::size_t count, double* out) {
  for (std::size_t a = 0; a + 2 < count; ++a)
    out[a] = angleBetween(x[a + 1] - x[a], y[a + 1] - y[a], x[a + 2] - x[a + 1], y[a + 2] - y[a + 1]);
}

}  // namespace llc
