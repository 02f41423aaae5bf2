#include "laser_loop_closure/core/io/scan_codec.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace llc {
namespace {

constexpr std::uint8_t kMagic[4] = {'L', 'S', 'C', '2'};
constexpr std::uint8_t kOldMagic[4] = {'L', 'S', 'C', '1'};
constexpr std::size_t kHeader = 4 + 4 + 8 + 8 + 1 + 1 + 8;  // magic, beams, steps, full_circle, origins, base increment
constexpr std::size_t kOriginBytes = 24;  // x, y, increment
constexpr std::uint32_t kMostBeams = 1u << 20;
constexpr std::size_t kMostOrigins = 4;          ///< scanners found besides the base origin (source 0)
constexpr double kFarthestOrigin = 1000.0;       ///< m: a scanner further from the base: corrupt
constexpr std::size_t kMostVarintBytes = 10;
constexpr std::int64_t kLargestStep = std::int64_t(1) << 40;  ///< larger differences: corrupt (and no overflow)
constexpr std::uint8_t kNoReturn = 0x80;         ///< in a beam's source byte: no range follows

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

struct Point {
  double x = 0.0, y = 0.0;
};

/// What writer and reader both track per source (an origin the beams are seen from, and the
/// angle between its neighbouring beams): the last beam's direction from there as written
/// (rad) and its range from there in range steps.
struct SourceTrack {
  double direction = 0.0;
  std::int64_t range = 0;
};

/// A beam's direction from its source, written as the beams it steps past the source's last
/// one (1 for the next beam of an even run) and what is left, in bearing steps (0 there).
struct DirectionCode {
  std::int64_t beams = 0, rest = 0;
  double direction = 0.0;  ///< as the reader gets it back
};

DirectionCode codeDirection(const SourceTrack& track, double increment, double bearing_step, double direction) {
  const double turn = normalizeAngle(direction - track.direction);
  DirectionCode code;
  code.beams = std::llround(turn / increment);
  code.rest = std::llround((turn - double(code.beams) * increment) / bearing_step);
  code.direction = track.direction + double(code.beams) * increment + double(code.rest) * bearing_step;
  return code;
}

/// The angle between neighbouring beams seen from an origin: the median of the steps between
/// beams of one even run from there (those given by `even`), else of all steps.
template <class Even>
double beamIncrement(const std::vector<double>& seen, Even&& even, double bearing_step) {
  std::vector<double> steps, all;
  for (std::size_t k = 0; k + 1 < seen.size(); ++k) {
    const double step = normalizeAngle(seen[k + 1] - seen[k]);
    all.push_back(step);
    if (even(k)) steps.push_back(step);
  }
  std::vector<double>& use = steps.size() >= 3 ? steps : all;
  if (use.empty()) return bearing_step;
  std::nth_element(use.begin(), use.begin() + long(use.size() / 2), use.end());
  const double median = use[use.size() / 2];
  return median > bearing_step && median < 1.0 ? median : bearing_step;
}

/// Fits the origin from which a run of consecutive points is seen at evenly stepping directions
/// (the scanner that measured them): Gauss-Newton on the directions' second differences, from
/// the base origin. False when they do not step evenly from anywhere near (another scanner's
/// beams among them, or a degenerate run).
bool fitScannerOrigin(const std::vector<Point>& run, double tolerance, Point* origin) {
  Point o;
  const std::size_t n = run.size();
  std::vector<double> direction(n), dx(n), dy(n);
  double rms = 0.0;
  for (int iteration = 0; iteration < 12; ++iteration) {
    for (std::size_t k = 0; k < n; ++k) {
      const double x = run[k].x - o.x, y = run[k].y - o.y, d2 = x * x + y * y;
      if (d2 < 1e-6) return false;
      direction[k] = std::atan2(y, x);
      dx[k] = y / d2;  // d direction / d origin.x
      dy[k] = -x / d2;
    }
    double a = 0.0, b = 0.0, c = 0.0, gx = 0.0, gy = 0.0, sum = 0.0;
    for (std::size_t k = 1; k + 1 < n; ++k) {
      const double e = normalizeAngle(direction[k + 1] - direction[k]) - normalizeAngle(direction[k] - direction[k - 1]);
      const double jx = dx[k + 1] - 2.0 * dx[k] + dx[k - 1], jy = dy[k + 1] - 2.0 * dy[k] + dy[k - 1];
      a += jx * jx, b += jx * jy, c += jy * jy, gx += jx * e, gy += jy * e, sum += e * e;
    }
    rms = std::sqrt(sum / double(n - 2));
    const double det = a * c - b * b;
    if (!(det > 0.0)) return false;
    const double step_x = (c * gx - b * gy) / det, step_y = (a * gy - b * gx) / det;
    o.x -= step_x, o.y -= step_y;
    if (std::hypot(o.x, o.y) > 10.0) return false;  // no mount is that far from its base
    if (std::hypot(step_x, step_y) < 1e-7) break;
  }
  *origin = o;
  return rms < tolerance;
}

/// The scanners' origins in the base frame, found from runs of returns that step evenly seen
/// from one point: clusters of run fits (2 or more runs within 1 cm), largest first; an origin
/// at the base origin is left out (source 0 is that).
std::vector<Point> findScannerOrigins(const std::vector<Point>& points, const std::vector<bool>& returned,
                                      double bearing_step) {
  constexpr std::size_t kRun = 12;
  std::vector<Point> fits;
  for (std::size_t start = 0; start + kRun <= points.size(); start += kRun / 2) {
    if (!std::all_of(returned.begin() + long(start), returned.begin() + long(start + kRun), [](bool r) { return r; })) continue;
    Point origin;
    if (fitScannerOrigin({points.begin() + long(start), points.begin() + long(start + kRun)}, 0.25 * bearing_step, &origin))
      fits.push_back(origin);
  }
  std::vector<Point> origins;
  while (origins.size() < 2 && fits.size() >= 2) {
    auto near = [&](const Point& a, const Point& b) { return std::hypot(a.x - b.x, a.y - b.y) < 0.01; };
    std::size_t best = 0, best_count = 0;
    for (std::size_t i = 0; i < fits.size(); ++i) {
      const auto count = std::size_t(std::count_if(fits.begin(), fits.end(), [&](const Point& f) { return near(f, fits[i]); }));
      if (count > best_count) best = i, best_count = count;
    }
    if (best_count < 2) break;
    const Point centre = fits[best];
    Point mean;
    for (const Point& f : fits)
      if (near(f, centre)) mean.x += f.x / double(best_count), mean.y += f.y / double(best_count);
    fits.erase(std::remove_if(fits.begin(), fits.end(), [&](const Point& f) { return near(f, centre); }), fits.end());
    if (std::hypot(mean.x, mean.y) >= 0.01) origins.push_back(mean);
  }
  return origins;
}

double costBits(std::int64_t value) { return std::log2(1.0 + double(std::abs(value))); }

}  // namespace

std::string ScanPackOptions::validate() const {
  if (!(range_step > 0.0) || !std::isfinite(range_step)) return "range_step must be > 0";
  if (!(bearing_step > 0.0) || !std::isfinite(bearing_step)) return "bearing_step must be > 0";
  if (beam_stride < 1 || beam_stride > kMostBeams) return "beam_stride must be 1 to 2^20";
  return "";
}

std::vector<std::uint8_t> packScan(const Scan& scan, const ScanPackOptions& options) {
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw std::invalid_argument("scan packing: " + invalid);
  if (scan.ranges.size() != scan.bearings.size()) throw std::invalid_argument("scan packing: ranges and bearings differ in length");
  if (scan.ranges.size() > kMostBeams) throw std::invalid_argument("scan packing: too many beams");
  const double most = double(std::numeric_limits<std::int32_t>::max()) * options.range_step;
  std::vector<Point> points;
  std::vector<double> bearings;
  std::vector<bool> returned;
  for (std::size_t k = 0; k < scan.size(); k += options.beam_stride) {
    const double bearing = scan.bearings[k], range = scan.ranges[k];
    if (!std::isfinite(bearing) || std::abs(bearing) > 1.0e6) throw std::invalid_argument("scan packing: a bearing is not finite");
    returned.push_back(std::isfinite(range) && range > 0.0 && range < most);
    bearings.push_back(bearing);
    points.push_back(returned.back() ? Point{range * std::cos(bearing), range * std::sin(bearing)} : Point{});
  }
  std::vector<Point> origins{Point{}};
  for (const Point& o : findScannerOrigins(points, returned, options.bearing_step)) origins.push_back(o);

  // Each beam from a source it steps evenly from, with a neighbour on either side or two on
  // one side (it continues the run of the beam before it where it can); a beam that steps
  // evenly from none, from the source whose track predicts it best. Written: its direction from
  // there (unwrapped next to the predicted one) and its range from there.
  const std::size_t n = points.size();
  std::vector<std::vector<double>> seen(origins.size(), std::vector<double>(n));
  for (std::size_t s = 0; s < origins.size(); ++s)
    for (std::size_t k = 0; k < n; ++k)
      seen[s][k] = returned[k] ? std::atan2(points[k].y - origins[s].y, points[k].x - origins[s].x) : bearings[k];  // no return: its ray
  auto even = [&](std::size_t s, std::size_t first) {  // beams first .. first + 2 step evenly from source s
    return first + 2 < n &&
           std::abs(normalizeAngle(seen[s][first + 2] - seen[s][first + 1]) - normalizeAngle(seen[s][first + 1] - seen[s][first])) <
               0.5 * options.bearing_step;
  };
  std::vector<double> increments;
  for (std::size_t s = 0; s < origins.size(); ++s)
    increments.push_back(beamIncrement(seen[s], [&](std::size_t k) { return even(s, k); }, options.bearing_step));
  std::vector<std::uint8_t> sources, directions, ranges;
  std::vector<SourceTrack> tracks(origins.size());
  std::size_t last_source = 0;
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t best = origins.size();
    for (std::size_t s = 0; s < origins.size(); ++s) {
      const bool evenly = (k >= 1 && even(s, k - 1)) || (k >= 2 && even(s, k - 2)) || even(s, k);
      if (evenly && (best == origins.size() || s == last_source)) best = s;
    }
    double best_cost = std::numeric_limits<double>::infinity();
    DirectionCode best_direction;
    std::int64_t best_range = 0;
    for (std::size_t s = 0; s < origins.size(); ++s) {
      if (best < origins.size() && s != best) continue;
      const SourceTrack& t = tracks[s];
      const DirectionCode direction = codeDirection(t, increments[s], options.bearing_step, seen[s][k]);
      const double x = points[k].x - origins[s].x, y = points[k].y - origins[s].y;
      const std::int64_t range = returned[k] ? std::max<std::int64_t>(1, std::llround(std::hypot(x, y) / options.range_step)) : t.range;
      const double cost = costBits(direction.beams - 1) + costBits(direction.rest) + costBits(range - t.range);
      if (cost < best_cost) best = s, best_cost = cost, best_direction = direction, best_range = range;
    }
    SourceTrack& t = tracks[best];
    sources.push_back(std::uint8_t(best) | (returned[k] ? 0 : kNoReturn));
    putVarint(directions, best_direction.beams - 1);
    putVarint(directions, best_direction.rest);
    t.direction = best_direction.direction;
    if (returned[k]) {
      putVarint(ranges, best_range - t.range);
      t.range = best_range;
    }
    last_source = best;
  }
  std::vector<std::uint8_t> plain = std::move(sources);
  plain.insert(plain.end(), directions.begin(), directions.end());
  plain.insert(plain.end(), ranges.begin(), ranges.end());

  uLongf deflated_size = compressBound(uLong(plain.size()));
  std::vector<std::uint8_t> out;
  out.insert(out.end(), kMagic, kMagic + 4);
  putRaw(out, std::uint32_t(points.size()));
  putRaw(out, options.range_step);
  putRaw(out, options.bearing_step);
  out.push_back(scan.full_circle ? 1 : 0);
  out.push_back(std::uint8_t(origins.size() - 1));
  putRaw(out, increments[0]);
  for (std::size_t s = 1; s < origins.size(); ++s) putRaw(out, origins[s].x), putRaw(out, origins[s].y), putRaw(out, increments[s]);
  const std::size_t body = out.size();
  out.resize(body + deflated_size);
  if (compress2(out.data() + body, &deflated_size, plain.data(), uLong(plain.size()), Z_BEST_COMPRESSION) != Z_OK)
    throw std::runtime_error("scan packing: zlib failed");
  out.resize(body + deflated_size);
  return out;
}

bool unpackScan(const std::vector<std::uint8_t>& packed, Scan* scan, std::string* error) {
  auto fail = [&](const std::string& why) {
    *error = "packed scan: " + why;
    return false;
  };
  if (packed.size() >= 4 && std::memcmp(packed.data(), kOldMagic, 4) == 0)
    return fail("LSC1, the packing of version 0.13.0: send it again from a front end of this version");
  if (packed.size() < kHeader || std::memcmp(packed.data(), kMagic, 4) != 0) return fail("not a packed scan");
  const auto beams = getRaw<std::uint32_t>(packed, 4);
  const auto range_step = getRaw<double>(packed, 8);
  const auto bearing_step = getRaw<double>(packed, 16);
  const std::size_t origin_count = packed[25];
  if (beams > kMostBeams) return fail("more beams than a scan has (" + std::to_string(beams) + ")");
  if (!(range_step > 0.0) || !(bearing_step > 0.0) || !std::isfinite(range_step) || !std::isfinite(bearing_step))
    return fail("steps not positive");
  if (origin_count > kMostOrigins || packed.size() < kHeader + kOriginBytes * origin_count)
    return fail("a corrupt list of scanner origins");
  std::vector<Point> origins{Point{}};
  std::vector<double> increments{getRaw<double>(packed, kHeader - 8)};
  for (std::size_t s = 0; s < origin_count; ++s) {
    const std::size_t at = kHeader + kOriginBytes * s;
    origins.push_back({getRaw<double>(packed, at), getRaw<double>(packed, at + 8)});
    increments.push_back(getRaw<double>(packed, at + 16));
    if (!(std::hypot(origins.back().x, origins.back().y) < kFarthestOrigin)) return fail("a scanner origin beyond 1 km");
  }
  for (const double increment : increments)
    if (!(increment > 0.0 && increment < 2.0 * M_PI)) return fail("a corrupt angle between beams");
  const std::size_t body = kHeader + kOriginBytes * origin_count;
  std::vector<std::uint8_t> plain(std::size_t(beams) * (1 + 3 * kMostVarintBytes) + 1);
  uLongf plain_size = uLongf(plain.size());
  if (uncompress(plain.data(), &plain_size, packed.data() + body, uLong(packed.size() - body)) != Z_OK)
    return fail("corrupt or truncated");
  plain.resize(plain_size);
  if (plain.size() < beams) return fail("truncated sources");
  std::vector<SourceTrack> tracks(origins.size());
  std::vector<double> direction_of(beams);
  std::size_t at = beams;
  for (std::uint32_t k = 0; k < beams; ++k) {
    const std::size_t s = plain[k] & ~kNoReturn;
    if (s >= origins.size()) return fail("a beam of an unknown source");
    SourceTrack& t = tracks[s];
    std::int64_t beams_on = 0, rest = 0;
    if (!getVarint(plain, at, &beams_on) || !getVarint(plain, at, &rest) || std::abs(beams_on) > kMostBeams ||
        std::abs(rest) > kLargestStep)
      return fail("truncated or corrupt directions");
    t.direction += double(beams_on + 1) * increments[s] + double(rest) * bearing_step;
    if (!(std::abs(t.direction) < 1.0e9)) return fail("corrupt directions");
    direction_of[k] = t.direction;
  }
  Scan out;
  out.full_circle = packed[24] != 0;
  out.stamp = scan->stamp;
  out.bearings.reserve(beams);
  out.ranges.reserve(beams);
  for (std::uint32_t k = 0; k < beams; ++k) {
    const std::size_t s = plain[k] & ~kNoReturn;
    const double direction = direction_of[k];
    if (plain[k] & kNoReturn) {
      out.bearings.push_back(normalizeAngle(direction));
      out.ranges.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    SourceTrack& t = tracks[s];
    std::int64_t delta = 0;
    if (!getVarint(plain, at, &delta) || std::abs(delta) > kLargestStep) return fail("truncated or corrupt ranges");
    t.range += delta;
    if (t.range <= 0) return fail("a range not positive");
    const double range = double(t.range) * range_step;
    const double x = origins[s].x + range * std::cos(direction), y = origins[s].y + range * std::sin(direction);
    out.bearings.push_back(std::atan2(y, x));
    out.ranges.push_back(std::hypot(x, y));
  }
  if (at != plain.size()) return fail("bytes after the last range");
  // Beams by increasing bearing (Scan360's order), as they were before rounding moved them.
  std::vector<std::size_t> order(beams);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return out.bearings[a] < out.bearings[b]; });
  Scan sorted;
  sorted.full_circle = out.full_circle;
  sorted.stamp = out.stamp;
  sorted.bearings.reserve(beams);
  sorted.ranges.reserve(beams);
  for (const std::size_t k : order) sorted.bearings.push_back(out.bearings[k]), sorted.ranges.push_back(out.ranges[k]);
  *scan = std::move(sorted);
  return true;
}

}  // namespace llc
