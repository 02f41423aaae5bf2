#include "laser_loop_closure/core/io/compact_scan.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

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
    : beams_(scan.ranges.size()), ranges_(scan.ranges), stamp_(scan.stamp), full_circle_(scan.full_circle) {
  if (same_beams && same_beams->bearings_ && same_beams->bearings_->equals(scan.bearings))
    bearings_ = same_beams->bearings_, shares_bearings_ = true;
  else
    bearings_ = std::make_shared<const CompactValues>(scan.bearings);
}

CompactScan CompactScan::packed(const Scan& scan, const ScanPackOptions& packing) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = packScan(scan, packing);
  } catch (const std::invalid_argument&) {
    return CompactScan(scan);  // kept as it came: its users judge it
  }
  CompactScan compact;
  compact.beams_ = scan.ranges.size();
  compact.packed_ = std::move(bytes);
  compact.packed_.shrink_to_fit();
  compact.stamp_ = scan.stamp;
  compact.full_circle_ = scan.full_circle;
  return compact;
}

Scan CompactScan::scan() const {
  Scan scan;
  if (!packed_.empty()) {
    std::string error;
    if (!unpackScan(packed_, &scan, &error)) throw std::logic_error("a scan packed here does not unpack: " + error);
  } else {
    scan.ranges = ranges_.values();
    scan.bearings = bearings_->values();
  }
  scan.stamp = stamp_;
  scan.full_circle = full_circle_;
  return scan;
}

std::size_t CompactScan::bytes() const {
  return sizeof(*this) + packed_.capacity() + ranges_.bytes() +
         (shares_bearings_ || !bearings_ ? 0 : sizeof(CompactValues) + bearings_->bytes());
}

namespace {

/// The packing map_scan_step stands for: the same error along and (at 50 m) across.
ScanPackOptions mapScanPacking(double pack_step) {
  ScanPackOptions packing;
  packing.range_step = pack_step;
  packing.bearing_step = pack_step / 50.0;
  return packing;
}

}  // namespace

std::shared_ptr<const CompactScan> mapScanAtRest(const Scan& scan, double pack_step, const CompactScan* before) {
  if (pack_step > 0.0) return std::make_shared<const CompactScan>(CompactScan::packed(scan, mapScanPacking(pack_step)));
  return std::make_shared<const CompactScan>(scan, before);
}

std::string checkMapScanStep(double pack_step) {
  if (!(pack_step >= 0.0) || !std::isfinite(pack_step)) return "must be 0 (kept exact) or a step > 0 in metres";
  return pack_step > 0.0 ? mapScanPacking(pack_step).validate() : "";
}

}  // namespace llc
