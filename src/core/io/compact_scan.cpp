#include "laser_loop_closure/core/io/compact_scan.hpp"
#include "laser_loop_closure/core/io/range_coder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace llc {

namespace {

bool sameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

/// A float's bits as an integer in the floats' order (-0 just below +0), and back: neighbouring
/// floats are neighbouring integers, so a smooth run of values is a smooth run of integers.
std::int64_t orderedBits(float value) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  return (bits & 0x80000000u) ? -std::int64_t(bits & 0x7fffffffu) - 1 : std::int64_t(bits);
}

float fromOrderedBits(std::int64_t ordered) {
  const std::uint32_t bits = ordered >= 0 ? std::uint32_t(ordered) : (0x80000000u | std::uint32_t(-(ordered + 1)));
  float value = 0.0f;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

/// The models of one coded array, the same in writer and reader. Values that are not finite
/// (no return) are flagged and coded apart, against the last of them, so that they neither
/// cost much when they repeat nor spoil the prediction of the finite ones.
struct FloatCoding {
  BitModel not_finite;
  IntegerModel finite, other;
  SequencePredictor predictor{1 << 16, std::int64_t(1) << 56};  // a jump of 65,536 floats: an edge, not a slope
  std::int64_t last_other = 0;
};

std::vector<std::uint8_t> codeFloats(const std::vector<double>& values) {
  if (values.empty()) return {};
  RangeEncoder coder;
  FloatCoding models;
  for (const double value : values) {
    const std::int64_t ordered = orderedBits(float(value));
    const bool finite = std::isfinite(value);
    coder.encode(models.not_finite, !finite);
    if (finite) {
      models.finite.encode(coder, ordered - models.predictor.next());
      models.predictor.add(ordered);
    } else {
      models.other.encode(coder, ordered - models.last_other);
      models.last_other = ordered;
    }
  }
  std::vector<std::uint8_t> coded = coder.finish();
  coded.shrink_to_fit();
  return coded;
}

std::vector<double> decodeFloats(const std::vector<std::uint8_t>& coded, std::size_t count) {
  if (count == 0) return {};
  std::vector<double> values;
  values.reserve(count);
  RangeDecoder coder(coded.data(), coded.size());
  FloatCoding models;
  for (std::size_t k = 0; k < count; ++k) {
    std::int64_t residual = 0;
    const bool finite = !coder.decode(models.not_finite);
    if (!(finite ? models.finite : models.other).decode(coder, &residual))
      throw std::logic_error("compact values: coded floats do not decode");
    const std::int64_t ordered = residual + (finite ? models.predictor.next() : models.last_other);
    if (finite) models.predictor.add(ordered);
    else models.last_other = ordered;
    values.push_back(double(fromOrderedBits(ordered)));
  }
  if (coder.overrun()) throw std::logic_error("compact values: coded floats end early");
  return values;
}

}  // namespace

CompactValues::CompactValues(const std::vector<double>& values) : count_(values.size()) {
  const bool single = std::all_of(values.begin(), values.end(),
                                  [](double v) { return std::isnan(v) || double(float(v)) == v; });
  if (single)
    coded_ = codeFloats(values);
  else
    wide_ = values;
}

std::vector<double> CompactValues::values() const {
  if (!wide_.empty()) return wide_;
  return decodeFloats(coded_, count_);
}

bool CompactValues::equals(const std::vector<double>& values) const {
  if (values.size() != size()) return false;
  const std::vector<double> held = this->values();
  return std::equal(values.begin(), values.end(), held.begin(), sameValue);
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
