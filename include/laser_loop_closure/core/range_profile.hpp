// A coarse polar range profile of a scan, and the distance of two profiles at the best
// relative rotation: a pair feature that is rotation-invariant by search rather than by
// construction, so that it keeps the layout of the place (which the per-scan statistics lose).
#pragma once

#include <cstddef>

namespace llc {

/// Sectors of the full circle; sector s spans bearings [-pi + s w, -pi + (s + 1) w), w = 2 pi / kProfileSectors.
constexpr std::size_t kProfileSectors = 36;
/// Sector value of a sector no beam falls in (a 180-degree scan leaves half of them empty).
constexpr double kProfileEmpty = -100.0;
/// m; ranges are floored here before the logarithm (a beam cannot be nearer than this).
constexpr double kProfileMinRange = 0.1;
/// m; a sector whose mean log-range is below log(this) is marked empty (hidden by clutter).
constexpr double kProfileNearRange = 1.0;
/// Fewest shared sectors a rotation must leave, as a fraction of the smaller coverage.
constexpr double kProfileMinOverlap = 0.5;
/// Distance of profiles that cannot be compared: more than any two log-ranges differ by.
constexpr double kProfileNoOverlap = 100.0;

/// Writes kProfileSectors values: per sector, the mean of log(r / 1 m) over its beams, r clipped
/// to [kProfileMinRange, r_max] (beams without a valid return count as r_max), or kProfileEmpty
/// when no beam falls in it or that mean is below log(kProfileNearRange).
/// Logarithms, so that a difference is a ratio of ranges, which suits near and far walls alike.
void writeRangeProfile(const double* bearings, const double* clipped_ranges, std::size_t beams, double* out);
/// Sector of a bearing (any angle, wrapped), or kProfileSectors when it is not finite.
std::size_t profileSector(double bearing);
/// The same profile from each beam's profileSector, for callers that cache the sectors of a
/// fixed beam layout.
void writeRangeProfileBySector(const std::size_t* sectors, const double* clipped_ranges, std::size_t beams, double* out);

/// Mean absolute difference of two profiles over the sectors both cover, minimised over every
/// rotation of b by a whole number of sectors that leaves enough overlap. Symmetric, >= 0,
/// 0 for a profile and any whole-sector rotation of it; kProfileNoOverlap when no rotation
/// leaves enough overlap.
/// Computed in single precision: profiles are coarse, and the keyframe store keeps them so.
double profileDistance(const double* a, const double* b);
/// The same; with stop_below > 0 it may stop at the first rotation closer than stop_below and
/// return that distance (which is then below stop_below, as the minimum is): enough for a
/// classifier whose profile thresholds are all at or above stop_below, and cheaper.
/// With reject_at_or_above finite it may also give up on a pair whose distance is at least
/// that, and then returns some value >= reject_at_or_above (for a classifier that drops the
/// pair whenever the distance is that large).
double profileDistance(const float* a, const float* b, double stop_below = -1.0,
                       double reject_at_or_above = kProfileNoOverlap);

}  // namespace llc
