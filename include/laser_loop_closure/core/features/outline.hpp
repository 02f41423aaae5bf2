// The outline of a scan resampled at an even spacing along its length, so that its points no
// longer depend on where the scanner stood: a wall near the robot gets many beams per metre, the
// same wall seen from afar few. Shape distributions over these points (Osada's D2, distances to
// their centroid) then describe the visible geometry itself, hardly the viewpoint.
#pragma once

#include <cstddef>

namespace llc {

/// m; neighbouring valid points closer than this are joined into one stretch of outline.
constexpr double kOutlineLink = 0.5;
/// m; the spacing of the resampled points along the outline ...
constexpr double kOutlineSpacing = 0.25;
/// ... unless the outline is longer than this many spacings: then its length / this.
constexpr std::size_t kOutlineTarget = 128;
/// Most points resampleOutline writes: the resampled ones plus one per stretch, which only a
/// scan of scattered clutter can push past this.
constexpr std::size_t kOutlineMaxPoints = 2 * kOutlineTarget;

/// Resamples the outline of n points (x, y; valid[i] nonzero for a real return; step[i] the
/// distance from point i to the next, step[n - 1] from the last to the first on a closed ring).
/// Each stretch of joined points (a lone point is a stretch too) gives its first point and then
/// a point every spacing along it; what is left of its length under one spacing gives none.
/// On a closed ring stretches continue through the seam and the result is the same for any
/// cyclic shift of the beams, up to a cyclic shift of the points (unless the cap cut it short).
/// Writes at most kOutlineMaxPoints points to out_x, out_y, in beam order, and returns their number.
std::size_t resampleOutline(const double* x, const double* y, const unsigned char* valid, const double* step,
                            std::size_t n, bool closed, double* out_x, double* out_y);

}  // namespace llc
