#include "laser_loop_closure/core/sim/sim_drive.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/common/random.hpp"

namespace llc {
namespace {

constexpr double kLaneOffset = 2.0;   // m right of the street centre line
constexpr double kTurnRadius = 9.0;   // m, on the centre line
constexpr double kEgoHalfWidth = 0.9;  // m; half the ego vehicle's width, around its axis (base to scanners)

/// A path of poses at arc length s: straight pieces and circular arcs.
struct PathPiece {
  Pose2 start;
  double length = 0.0;
  double curvature = 0.0;  // 1/m, + left
  Pose2 at(double s) const {
    if (std::abs(curvature) < 1e-12)
      return {start.x + std::cos(start.theta) * s, start.y + std::sin(start.theta) * s, start.theta};
    const double r = 1.0 / curvature, theta = start.theta + s * curvature;
    return {start.x + r * (std::sin(theta) - std::sin(start.theta)),
            start.y - r * (std::cos(theta) - std::cos(start.theta)), normalizeAngle(theta)};
  }
};

}  // namespace

std::string SimDriveOptions::validate() const {
  if (!(std::isfinite(length_m) && length_m > 0)) return "--length-m must be a positive number of metres";
  if (length_m > 200000.0) return "--length-m must be at most 200000 (200 km)";
  if (!(std::isfinite(rate_hz) && rate_hz > 0 && rate_hz <= 100)) return "--rate-hz must be in (0, 100]";
  if (!(std::isfinite(speed) && speed > 0)) return "speed must be positive";
  if (!(std::isfinite(parking_mean_s) && parking_mean_s >= 1.0)) return "--parking-mean-s must be at least 1 second";
  return {};
}

SimScannerOptions simFrontScanner() {
  SimScannerOptions s;
  s.name = "front";
  s.mount = {1.5, 0.0, 0.0};
  return s;
}

SimScannerOptions simBackScanner() {
  SimScannerOptions s;
  s.name = "back";
  s.mount = {-1.0, 0.0, M_PI};
  return s;
}

double simBeamAngle(const SimScannerOptions& scanner, std::size_t i) {
  return -M_PI / 2 + M_PI * double(i) / double(scanner.beams - 1);
}

WorldOptions simWorldOptions(const SimDriveOptions& options) {
  WorldOptions world;
  world.seed = options.seed;
  // Enough blocks that a long route wanders, few enough that it comes back.
  const int blocks = std::clamp(int(std::ceil(std::sqrt(options.length_m / 100.0))), 3, 12);
  world.blocks_x = world.blocks_y = blocks;
  world.duration = options.length_m / (0.5 * options.speed) + 60.0;
  world.parking_mean_s = options.parking_mean_s;
  return world;
}

SimDrive simulateDrive(const SimWorld& world, const SimDriveOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument(error);
  const auto wall_start = std::chrono::steady_clock::now();
  SimDrive drive;
  drive.options = options;
  drive.front = simFrontScanner();
  drive.back = simBackScanner();
  Random random((options.route_seed != 0 ? options.route_seed : options.seed) * 0xD1B54A32D192ED03ULL + 5);

  // Route: a walk on the street grid without U-turns, preferring to turn towards places
  // already visited now and then so that loops of every size appear.
  const int nx = world.options().blocks_x, ny = world.options().blocks_y;
  const double pitch = world.options().block_pitch;
  int i = int(random.index(std::uint64_t(nx + 1))), j = int(random.index(std::uint64_t(ny + 1)));
  int di = 1, dj = 0;
  if (i == nx) di = -1;
  std::vector<std::pair<int, int>> nodes = {{i, j}};
  const double edges_needed = std::ceil(options.length_m / pitch) + 1;
  while (double(nodes.size()) < edges_needed + 1) {
    std::vector<std::pair<int, int>> moves;
    for (const auto& [a, b] : {std::pair{di, dj}, {-dj, di}, {dj, -di}}) {  // straight, left, right
      const int ni = i + a, nj = j + b;
      if (ni >= 0 && ni <= nx && nj >= 0 && nj <= ny) moves.push_back({a, b});
    }
    // (Some move always exists: a boundary node keeps one of left and right inside.)
    const auto [a, b] = moves[random.index(moves.size())];
    di = a, dj = b;
    i += a, j += b;
    nodes.push_back({i, j});
  }
  // Pieces: straight between intersections, quarter arcs in turns, on the centre line; the
  // lane offset is applied when sampling.
  std::vector<PathPiece> pieces;
  for (std::size_t k = 0; k + 1 < nodes.size(); ++k) {
    const WorldPoint a = world.node(nodes[k].first, nodes[k].second), b = world.node(nodes[k + 1].first, nodes[k + 1].second);
    const double heading = std::atan2(b.y - a.y, b.x - a.x);
    // The walk never turns back, so every change of heading at a node is a quarter turn.
    double turn_in = 0.0, turn_out = 0.0, next_turn = 0.0;
    if (k > 0) {
      const WorldPoint p = world.node(nodes[k - 1].first, nodes[k - 1].second);
      if (std::abs(normalizeAngle(heading - std::atan2(a.y - p.y, a.x - p.x))) > 1e-6) turn_in = kTurnRadius;
    }
    if (k + 2 < nodes.size()) {
      const WorldPoint c = world.node(nodes[k + 2].first, nodes[k + 2].second);
      next_turn = normalizeAngle(std::atan2(c.y - b.y, c.x - b.x) - heading);
      if (std::abs(next_turn) > 1e-6) turn_out = kTurnRadius;
    }
    const Pose2 start{a.x + std::cos(heading) * turn_in, a.y + std::sin(heading) * turn_in, heading};
    pieces.push_back({start, pitch - turn_in - turn_out, 0.0});
    if (turn_out > 0.0) {
      const double curvature = (next_turn > 0 ? 1.0 : -1.0) / kTurnRadius;
      pieces.push_back({pieces.back().at(pieces.back().length), 0.5 * M_PI * kTurnRadius, curvature});
    }
    drive.route.push_back({a.x, a.y, heading});
  }
  // Sample at the scan rate, slower in turns.
  std::vector<double> piece_start(pieces.size() + 1, 0.0);
  for (std::size_t k = 0; k < pieces.size(); ++k) piece_start[k + 1] = piece_start[k] + pieces[k].length;
  const double total = std::min(options.length_m, piece_start.back());
  auto sample = [&](double s) {
    const std::size_t k = std::min(pieces.size() - 1,
                                   std::size_t(std::upper_bound(piece_start.begin(), piece_start.end(), s) - piece_start.begin()) - 1);
    const PathPiece& piece = pieces[k];
    Pose2 p = piece.at(s - piece_start[k]);
    p.x += std::sin(p.theta) * kLaneOffset;  // keep right
    p.y -= std::cos(p.theta) * kLaneOffset;
    return std::pair{p, std::abs(piece.curvature) > 0 ? 0.5 : 1.0};
  };
  const double dt = 1.0 / options.rate_hz;
  Pose2 odometry{0.0, 0.0, 0.0};
  Pose2 previous_truth;
  double s = 0.0, t = 0.0;
  const SimScannerOptions* scanners[2] = {&drive.front, options.back_scanner ? &drive.back : nullptr};
  while (s <= total) {
    const auto [truth, speed_factor] = sample(s);
    SimFrame frame;
    frame.stamp = t;
    frame.truth = truth;
    if (!drive.frames.empty()) {
      // Odometry: the true step with noise growing with distance and turn, and a bias.
      const Pose2 step = between(previous_truth, truth);
      const double distance = std::hypot(step.x, step.y);
      const double scale = 1.0 + options.odometry_scale_bias + random.normal(0.0, options.odometry_distance_noise);
      const double turn = step.theta * (1.0 + random.normal(0.0, options.odometry_turn_noise)) +
                          options.odometry_turn_bias * distance +
                          random.normal(0.0, options.odometry_turn_per_metre * std::sqrt(distance));
      odometry = compose(odometry, Pose2{step.x * scale, step.y * scale, turn});
    }
    frame.odometry = odometry;
    previous_truth = truth;
    // The ego vehicle's axis, base to scanners: no mover drives through it.
    std::vector<WorldPoint> ego = {{truth.x, truth.y}};
    for (const SimScannerOptions* scanner : scanners)
      if (scanner) {
        const Pose2 at = compose(truth, scanner->mount);
        ego.push_back({at.x, at.y});
      }
    const std::vector<WorldSegment> movers =
        world.moverOutlines(t, truth.x, truth.y, drive.front.max_range + 5.0, ego, kEgoHalfWidth);
    for (int k = 0; k < 2; ++k) {
      if (!scanners[k]) continue;
      const SimScannerOptions& scanner = *scanners[k];
      const Pose2 sensor = compose(truth, scanner.mount);
      std::vector<double>& ranges = k == 0 ? frame.front : frame.back;
      ranges.resize(scanner.beams);
      for (std::size_t b = 0; b < scanner.beams; ++b) {
        double r = world.castRay(sensor.x, sensor.y, sensor.theta + simBeamAngle(scanner, b), t, scanner.max_range, &movers);
        const double noise = random.normal(0.0, scanner.range_noise);
        if (random.uniform() < scanner.dropout) r = INFINITY;
        if (std::isfinite(r)) r = std::clamp(r + noise, 0.0, scanner.max_range);
        ranges[b] = r;
      }
    }
    drive.frames.push_back(std::move(frame));
    s += options.speed * speed_factor * dt;
    t += dt;
  }
  drive.seconds_to_simulate =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return drive;
}

}  // namespace llc
