#include "laser_loop_closure/core/io/scan_codec.hpp"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace llc {
namespace {

constexpr std::uint8_t kMagic[4] = {'L', 'S', 'C', '1'};
constexpr std::size_t kHeader = 4 + 4 + 8 + 8 + 1;  // magic, beams, steps, full_circle
constexpr std::uint32_t kMostBeams = 1u << 20;
constexpr std::size_t kMostVarintBytes = 10;
constexpr std::int64_t kLargestStep = std::int64_t(1) << 40;  ///< larger differences: corrupt (and no overflow)

void putVarint(std::vector<std::uint8_t>& out, std::int64_t value) {
  std::uint64_t zigzag = (std::uint64_t(value) << 1) ^ std::uint64_t(value >> 63);
  while (zigzag >= 0x80) {
    out.push_back(std::uint8_t(zigzag | 0x80));
    zigzag >>= 7;
  }
  out.push_back(std::uint8_t(zigzag));
}

bool getVarint(const std::vector<std::uint8_t>& in, std::size_t& at, std::int64_t* value) {
  std::uint64_t zigzag = 0;
  for (std::size_t shift = 0, n = 0; n < kMostVarintBytes; ++n, shift += 7) {
    if (at >= in.size()) return false;
    const std::uint8_t byte = in[at++];
    zigzag |= std::uint64_t(byte & 0x7f) << shift;
    if ((byte & 0x80) == 0) {
      *value = std::int64_t(zigzag >> 1) ^ -std::int64_t(zigzag & 1);
      return true;
    }
  }
  return false;
}

template <class T>
void putRaw(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

template <class T>
T getRaw(const std::vector<std::uint8_t>& in, std::size_t at) {
  T value;
  std::memcpy(&value, in.data() + at, sizeof(T));
  return value;
}

}  // namespace

std::string ScanPackOptions::validate() const {
  if (!(range_step > 0.0) || !std::isfinite(range_step)) return "range_step must be > 0";
  if (!(bearing_step > 0.0) || !std::isfinite(bearing_step)) return "bearing_step must be > 0";
  return "";
}

std::vector<std::uint8_t> packScan(const Scan& scan, const ScanPackOptions& options) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument("scan packing: " + invalid);
  if (scan.ranges.size() != scan.bearings.size()) throw std::invalid_argument("scan packing: ranges and bearings differ in length");
  if (scan.ranges.size() > kMostBeams) throw std::invalid_argument("scan packing: too many beams");
  // Differences of rounded values: consecutive beams differ little, so most take one byte.
  std::vector<std::uint8_t> plain;
  plain.reserve(scan.size() * 3);
  // Bearings step evenly within each scanner's run: second differences are near 0.
  std::int64_t previous = 0, previous_step = 0;
  for (const double bearing : scan.bearings) {
    if (!std::isfinite(bearing) || std::abs(bearing) > 1.0e6) throw std::invalid_argument("scan packing: a bearing is not finite");
    const std::int64_t q = std::llround(bearing / options.bearing_step);
    putVarint(plain, (q - previous) - previous_step);
    previous_step = q - previous;
    previous = q;
  }
  previous = 0;
  const double most = double(std::numeric_limits<std::int32_t>::max()) * options.range_step;
  for (const double range : scan.ranges) {
    // 0: no return (+inf); a return rounding to 0 steps is kept as one step.
    const std::int64_t q = std::isfinite(range) && range > 0.0 && range < most
                               ? std::max<std::int64_t>(1, std::llround(range / options.range_step))
                               : 0;
    putVarint(plain, q - previous);
    previous = q;
  }
  uLongf deflated_size = compressBound(uLong(plain.size()));
  std::vector<std::uint8_t> out;
  out.reserve(kHeader + deflated_size);
  out.insert(out.end(), kMagic, kMagic + 4);
  putRaw(out, std::uint32_t(scan.size()));
  putRaw(out, options.range_step);
  putRaw(out, options.bearing_step);
  out.push_back(scan.full_circle ? 1 : 0);
  out.resize(kHeader + deflated_size);
  if (compress2(out.data() + kHeader, &deflated_size, plain.data(), uLong(plain.size()), Z_BEST_COMPRESSION) != Z_OK)
    throw std::runtime_error("scan packing: zlib failed");
  out.resize(kHeader + deflated_size);
  return out;
}

bool unpackScan(const std::vector<std::uint8_t>& packed, Scan* scan, std::string* error) {
  auto fail = [&](const std::string& why) {
    *error = "packed scan: " + why;
    return false;
  };
  if (packed.size() < kHeader || std::memcmp(packed.data(), kMagic, 4) != 0) return fail("not a packed scan");
  const auto beams = getRaw<std::uint32_t>(packed, 4);
  const auto range_step = getRaw<double>(packed, 8);
  const auto bearing_step = getRaw<double>(packed, 16);
  if (beams > kMostBeams) return fail("more beams than a scan has (" + std::to_string(beams) + ")");
  if (!(range_step > 0.0) || !(bearing_step > 0.0) || !std::isfinite(range_step) || !std::isfinite(bearing_step))
    return fail("steps not positive");
  std::vector<std::uint8_t> plain(std::size_t(beams) * 2 * kMostVarintBytes + 1);
  uLongf plain_size = uLongf(plain.size());
  if (uncompress(plain.data(), &plain_size, packed.data() + kHeader, uLong(packed.size() - kHeader)) != Z_OK)
    return fail("corrupt or truncated");
  plain.resize(plain_size);
  Scan out;
  out.full_circle = packed[24] != 0;
  out.stamp = scan->stamp;
  out.bearings.reserve(beams);
  out.ranges.reserve(beams);
  std::size_t at = 0;
  std::int64_t value = 0, delta = 0, step = 0;
  for (std::uint32_t k = 0; k < beams; ++k) {
    if (!getVarint(plain, at, &delta) || std::abs(delta) > kLargestStep || std::abs(step + delta) > kLargestStep)
      return fail("truncated or corrupt bearings");
    step += delta;
    value += step;
    if (std::abs(value) > kLargestStep * 1024) return fail("corrupt bearings");
    out.bearings.push_back(double(value) * bearing_step);
  }
  value = 0;
  for (std::uint32_t k = 0; k < beams; ++k) {
    if (!getVarint(plain, at, &delta) || std::abs(delta) > kLargestStep) return fail("truncated or corrupt ranges");
    value += delta;
    if (value < 0) return fail("a negative range");
    out.ranges.push_back(value == 0 ? std::numeric_limits<double>::infinity() : double(value) * range_step);
  }
  if (at != plain.size()) return fail("bytes after the last range");
  *scan = std::move(out);
  return true;
}

}  // namespace llc
