#include "laser_loop_closure/core/geometry/compact_scan.hpp"

#include <algorithm>
#include <cmath>

namespace llc {

namespace {

bool sameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

}  // namespace

CompactValues::CompactValues(const std::vector<double>& values) {
  const bool single = std::all_of(values.begin(), values.end(),
                                  [](double v) { return std::isnan(v) || double(float(v)) == v; });
  if (single)
    single_.assign(values.begin(), values.end());
  else
    wide_ = values;
}

std::vector<double> CompactValues::values() const {
  if (!wide_.empty()) return wide_;
  return std::vector<double>(single_.begin(), single_.end());
}

bool CompactValues::equals(const std::vector<double>& values) const {
  if (values.size() != size()) return false;
  if (!wide_.empty()) return std::equal(values.begin(), values.end(), wide_.begin(), sameValue);
  return std::equal(values.begin(), values.end(), single_.begin(),
                    [](double a, float b) { return sameValue(a, double(b)); });
}

CompactScan::CompactScan(const Scan& scan, const CompactScan* same_beams)
    : ranges_(scan.ranges), stamp_(scan.stamp), full_circle_(scan.full_circle) {
  if (same_beams && same_beams->bearings_ && same_beams->bearings_->equals(scan.bearings))
    bearings_ = same_beams->bearings_, shares_bearings_ = true;
  else
    bearings_ = std::make_shared<const CompactValues>(scan.bearings);
}

Scan CompactScan::scan() const {
  Scan scan;
  scan.ranges = ranges_.values();
  scan.bearings = bearings_->values();
  scan.stamp = stamp_;
  scan.full_circle = full_circle_;
  return scan;
}

std::size_t CompactScan::bytes() const {
  return sizeof(*this) + ranges_.bytes() + (shares_bearings_ ? 0 : sizeof(CompactValues) + bearings_->bytes());
}

}  // namespace llc
