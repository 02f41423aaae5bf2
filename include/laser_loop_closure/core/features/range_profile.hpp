// A coarse polar range profile of a scan, and the distance of two profiles at the best
// relative rotation: a pair feature that is rotation-invariant by search rather than by
// construction, so that it keeps the layout of the place (which the per-scan statistics lose).
#pragma once

#include <cstddef>
#include <cstdint>

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
/// For the rotation t (sector s of a against sector s + t of b) the differences are summed in
/// float in ascending order of b's sector, then divided (in double) by the sectors shared.
double profileDistance(const double* a, const double* b);
/// The same. With reject_at_or_above below kProfileNoOverlap it may give up on a pair whose
/// distance is at least that, and then returns some value >= reject_at_or_above (for a
/// classifier that drops the pair whenever the distance is that large); any distance below it
/// is returned bit for bit.
double profileDistance(const float* a, const float* b, double reject_at_or_above = kProfileNoOverlap);

/// Bit s set when sector s of the profile is not kProfileEmpty.
std::uint64_t profilePresence(const float* profile);

/// The first profile of profileDistance prepared once, for comparing one profile (a query)
/// with many (the keyframes): its every rotation laid out so that one vector loop serves
/// eight rotations at once. distance(b, r) == profileDistance(a, b, r), bit for bit.
class ProfileComparer {
 public:
  explicit ProfileComparer(const float* a);
  double distance(const float* b, double reject_at_or_above = kProfileNoOverlap) const {
    return distance(b, profilePresence(b), reject_at_or_above);
  }
  /// The same with b's profilePresence(b) computed beforehand (a keyframe store keeps it).
  double distance(const float* b, std::uint64_t present_b, double reject_at_or_above) const;

 private:
  static constexpr std::size_t kGroups = (kProfileSectors + 7) / 8;  ///< rotations, eight per group
  static constexpr std::size_t kWindow = kProfileSectors + 8 * kGroups;
  /// values_[m] = a[(n - 1 - m) mod n] (0 when that sector is empty), present_[m] its 1/0:
  /// rotations t..t+7 against b's sector j read m = n - 1 - j + t onwards, contiguously.
  alignas(32) float values_[kWindow], present_[kWindow];
  std::uint64_t bits_ = 0;  ///< bit s: sector s of a present
  std::uint64_t rotated_[8 * kGroups] = {};  ///< rotation t of bits_ (bit j: sector j - t present), 0 past n
  int count_ = 0;
};

}  // namespace llc
