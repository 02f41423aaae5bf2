#include "laser_loop_closure/core/io/scan_codec.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/io/range_coder.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace llc {
namespace {

constexpr std::uint8_t kMagic[4] = {'L', 'S', 'C', '4'};
constexpr std::int64_t kJump = 64;  ///< range steps: a larger change is an edge, not a slant
/// How much of one range's miss the predictor counts: LSC4 an edge's worth, LSC3 (0.20) all.
constexpr std::int64_t kMissCap = kJump, kMissCapLsc3 = std::int64_t(1) << 56;
constexpr std::size_t kHeader = 4 + 4 + 4 + 4 + 1 + 1 + 4;  // magic, beams, steps, full_circle, origins, base increment
constexpr std::size_t kOriginBytes = 12;  // x, y, increment (float32)
constexpr std::uint32_t kMostBeams = 1u << 20;
constexpr std::size_t kMostOrigins = 4;          ///< scanners found besides the base origin (source 0)
constexpr double kFarthestOrigin = 1000.0;       ///< m: a scanner further from the base: corrupt
constexpr std::int64_t kLargestStep = std::int64_t(1) << 40;  ///< larger differences: corrupt (and no overflow)

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
/// (rad), and a prediction of the next range from there (range steps) from the last ones.
struct SourceTrack {
  explicit SourceTrack(std::int64_t miss_cap = kMissCap) : range(kJump, miss_cap) {}
  double direction = 0.0;
  SequencePredictor range;
  std::int64_t predictedRange() const { return range.next(); }
  void addRange(std::int64_t steps) { range.add(steps); }
};

/// The adaptive models of one packed scan, the same in writer and reader.
struct ScanModels {
  BitModel same_source;
  std::array<BitModel, 2> no_return;  ///< after a return, after none
  IntegerModel source, beams_on, rest, range;
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

/// A value as the header's float32 holds it.
double asFloat(double value) { return double(float(value)); }

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
  // The header holds float32: the writer works with the values the reader will get.
  const double range_step = asFloat(options.range_step), bearing_step = asFloat(options.bearing_step);
  const double most = double(std::numeric_limits<std::int32_t>::max()) * range_step;
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
  for (const Point& o : findScannerOrigins(points, returned, bearing_step)) origins.push_back({asFloat(o.x), asFloat(o.y)});

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
               0.5 * bearing_step;
  };
  std::vector<double> increments;
  for (std::size_t s = 0; s < origins.size(); ++s)
    increments.push_back(asFloat(beamIncrement(seen[s], [&](std::size_t k) { return even(s, k); }, bearing_step)));
  RangeEncoder coder;
  ScanModels models;
  std::vector<SourceTrack> tracks(origins.size());
  std::size_t last_source = 0;
  bool last_returned = true;
  for (std::size_t k = 0; k < n; ++k) {
    // Of the sources the beam steps evenly from (seen from far, a wrong one may too, within
    // the tolerance), the one whose codes cost least.
    std::array<bool, 1 + kMostOrigins> evenly{};  // per beam: no allocation on this path
    bool any_even = false;
    for (std::size_t s = 0; s < origins.size(); ++s) {
      evenly[s] = (k >= 1 && even(s, k - 1)) || (k >= 2 && even(s, k - 2)) || even(s, k);
      any_even = any_even || evenly[s];
    }
    std::size_t best = last_source;
    double best_cost = std::numeric_limits<double>::infinity();
    DirectionCode best_direction;
    std::int64_t best_range = 0, best_residual = 0;
    for (std::size_t s = 0; s < origins.size(); ++s) {
      if (any_even && !evenly[s]) continue;
      const SourceTrack& t = tracks[s];
      const DirectionCode direction = codeDirection(t, increments[s], bearing_step, seen[s][k]);
      const double x = points[k].x - origins[s].x, y = points[k].y - origins[s].y;
      const std::int64_t predicted = t.predictedRange();
      const std::int64_t range = returned[k] ? std::max<std::int64_t>(1, std::llround(std::hypot(x, y) / range_step)) : predicted;
      const double cost = costBits(direction.beams - 1) + costBits(direction.rest) + costBits(range - predicted);
      if (cost < best_cost) best = s, best_cost = cost, best_direction = direction, best_range = range,
                                  best_residual = range - predicted;
    }
    SourceTrack& t = tracks[best];
    coder.encode(models.same_source, best == last_source);
    if (best != last_source) models.source.encode(coder, std::int64_t(best));
    coder.encode(models.no_return[last_returned ? 0 : 1], !returned[k]);
    models.beams_on.encode(coder, best_direction.beams - 1);
    models.rest.encode(coder, best_direction.rest);
    t.direction = best_direction.direction;
    if (returned[k]) {
      models.range.encode(coder, best_residual);  // against the prediction the choice was made with
      t.addRange(best_range);
    }
    last_source = best;
    last_returned = returned[k];
  }
  std::vector<std::uint8_t> out;
  out.insert(out.end(), kMagic, kMagic + 4);
  putRaw(out, std::uint32_t(points.size()));
  putRaw(out, float(range_step));
  putRaw(out, float(bearing_step));
  out.push_back(scan.full_circle ? 1 : 0);
  out.push_back(std::uint8_t(origins.size() - 1));
  putRaw(out, float(increments[0]));
  for (std::size_t s = 1; s < origins.size(); ++s)
    putRaw(out, float(origins[s].x)), putRaw(out, float(origins[s].y)), putRaw(out, float(increments[s]));
  const std::vector<std::uint8_t> body = coder.finish();
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

bool unpackScan(const std::vector<std::uint8_t>& packed, Scan* scan, std::string* error) {
  auto fail = [&](const std::string& why) {
    *error = "packed scan: " + why;
    return false;
  };
  if (packed.size() >= 4 && std::memcmp(packed.data(), kMagic, 3) == 0 && (packed[3] == '1' || packed[3] == '2'))
    return fail(std::string(packed[3] == '1' ? "LSC1, the packing of version 0.13.0" : "LSC2, the packing of versions 0.14 to 0.19") +
                ": send it again from a front end of this version");
  if (packed.size() < kHeader || std::memcmp(packed.data(), kMagic, 3) != 0 || (packed[3] != '3' && packed[3] != '4'))
    return fail("not a packed scan");
  const std::int64_t miss_cap = packed[3] == '3' ? kMissCapLsc3 : kMissCap;  // LSC3: version 0.20's
  const auto beams = getRaw<std::uint32_t>(packed, 4);
  const double range_step = getRaw<float>(packed, 8), bearing_step = getRaw<float>(packed, 12);
  const std::size_t origin_count = packed[17];
  if (beams > kMostBeams) return fail("more beams than a scan has (" + std::to_string(beams) + ")");
  if (!(range_step > 0.0) || !(bearing_step > 0.0) || !std::isfinite(range_step) || !std::isfinite(bearing_step))
    return fail("steps not positive");
  if (origin_count > kMostOrigins || packed.size() < kHeader + kOriginBytes * origin_count)
    return fail("a corrupt list of scanner origins");
  std::vector<Point> origins{Point{}};
  std::vector<double> increments{getRaw<float>(packed, kHeader - 4)};
  for (std::size_t s = 0; s < origin_count; ++s) {
    const std::size_t at = kHeader + kOriginBytes * s;
    origins.push_back({getRaw<float>(packed, at), getRaw<float>(packed, at + 4)});
    increments.push_back(getRaw<float>(packed, at + 8));
    if (!(std::hypot(origins.back().x, origins.back().y) < kFarthestOrigin)) return fail("a scanner origin beyond 1 km");
  }
  for (const double increment : increments)
    if (!(increment > 0.0 && increment < 2.0 * M_PI)) return fail("a corrupt angle between beams");
  const std::size_t body = kHeader + kOriginBytes * origin_count;
  RangeDecoder coder(packed.data() + body, packed.size() - body);
  ScanModels models;
  std::vector<SourceTrack> tracks(origins.size(), SourceTrack(miss_cap));
  std::size_t last_source = 0;
  bool last_returned = true;
  Scan out;
  out.full_circle = packed[16] != 0;
  out.stamp = scan->stamp;
  out.bearings.reserve(beams);
  out.ranges.reserve(beams);
  for (std::uint32_t k = 0; k < beams; ++k) {
    std::int64_t source = std::int64_t(last_source);
    if (!coder.decode(models.same_source) && (!models.source.decode(coder, &source) || source < 0 || source >= std::int64_t(origins.size())))
      return fail("a beam of an unknown source");
    const auto s = std::size_t(source);
    const bool returned = !coder.decode(models.no_return[last_returned ? 0 : 1]);
    SourceTrack& t = tracks[s];
    std::int64_t beams_on = 0, rest = 0;
    if (!models.beams_on.decode(coder, &beams_on) || !models.rest.decode(coder, &rest) || std::abs(beams_on) > kMostBeams ||
        std::abs(rest) > kLargestStep || coder.overrun())
      return fail("truncated or corrupt directions");
    t.direction += double(beams_on + 1) * increments[s] + double(rest) * bearing_step;
    if (!(std::abs(t.direction) < 1.0e9)) return fail("corrupt directions");
    last_source = s, last_returned = returned;
    if (!returned) {
      out.bearings.push_back(normalizeAngle(t.direction));
      out.ranges.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    std::int64_t residual = 0;
    if (!models.range.decode(coder, &residual) || std::abs(residual) > kLargestStep || coder.overrun())
      return fail("truncated or corrupt ranges");
    const std::int64_t steps = t.predictedRange() + residual;
    if (steps <= 0 || steps > std::numeric_limits<std::int32_t>::max()) return fail("a range not positive or beyond 2^31 steps");
    t.addRange(steps);
    const double range = double(steps) * range_step;
    const double x = origins[s].x + range * std::cos(t.direction), y = origins[s].y + range * std::sin(t.direction);
    out.bearings.push_back(std::atan2(y, x));
    out.ranges.push_back(std::hypot(x, y));
  }
  if (coder.overrun()) return fail("truncated");
  if (coder.consumed() != packed.size() - body) return fail("bytes after the last beam");
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
