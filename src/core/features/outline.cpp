#include "laser_loop_closure/core/features/outline.hpp"

#include <algorithm>
#include <cmath>

namespace llc {

std::size_t resampleOutline(const double* x, const double* y, const unsigned char* valid, const double* step,
                            std::size_t n, bool closed, double* out_x, double* out_y) {
  if (n == 0) return 0;
  const std::size_t links = closed ? n : n - 1;  // link i joins point i to point i + 1 (mod n)
  auto next = [n](std::size_t i) { return i + 1 == n ? 0 : i + 1; };
  auto joined = [&](std::size_t i) { return i < links && valid[i] && valid[next(i)] && step[i] < kOutlineLink; };
  double length = 0.0;
  bool any_break = false;
  std::size_t start = 0;  // a point no stretch runs into, so none straddles it
  for (std::size_t i = 0; i < n; ++i) {
    if (joined(i)) length += step[i];
    else if (!any_break) any_break = true, start = closed ? next(i) : 0;  // an open scan's last link is never joined
  }
  const double spacing = std::max(kOutlineSpacing, length / double(kOutlineTarget));
  if (!any_break) {
    // One stretch round the whole ring: begin at its farthest point (the first of equals),
    // which moves with the beams under a cyclic shift.
    double farthest = -1.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double r2 = x[i] * x[i] + y[i] * y[i];
      if (r2 > farthest) farthest = r2, start = i;
    }
  }
  std::size_t count = 0;
  auto emit = [&](double px, double py) {
    if (count == kOutlineMaxPoints) return false;
    out_x[count] = px;
    out_y[count] = py;
    ++count;
    return true;
  };
  double carry = 0.0;  // arc length walked since the last point written
  for (std::size_t visited = 0, i = start; visited < n; ++visited, i = next(i)) {
    if (!valid[i]) continue;
    const bool continues = visited > 0 && joined(i == 0 ? n - 1 : i - 1);
    if (!continues) {  // a stretch (perhaps of one point) begins here
      if (!emit(x[i], y[i])) break;
      carry = 0.0;
    }
    if (!joined(i) || (!any_break && visited + 1 == n)) continue;  // an unbroken ring ends where it began
    const std::size_t j = next(i);
    const double d = step[i];
    double at = spacing - carry;  // along link i, from point i
    for (; at <= d; at += spacing)
      if (!emit(x[i] + (x[j] - x[i]) * (at / d), y[i] + (y[j] - y[i]) * (at / d))) return count;
    carry = d - (at - spacing);
  }
  return count;
}

}  // namespace llc
