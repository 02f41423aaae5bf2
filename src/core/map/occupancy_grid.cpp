#include "laser_loop_closure/core/map/occupancy_grid.hpp"

#include "laser_loop_closure/core/common/file_util.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace llc {
namespace {

/// Grid cells crossed from (x0, y0) to (x1, y1), end cell excluded (integer DDA, Bresenham).
template <typename Visit>
void traverse(int x0, int y0, int x1, int y1, Visit&& visit) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int error = dx + dy;
  while (x0 != x1 || y0 != y1) {
    visit(x0, y0);
    const int twice = 2 * error;
    if (twice >= dy) error += dy, x0 += sx;
    if (twice <= dx) error += dx, y0 += sy;
  }
}

std::string baseName(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string directoryOf(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

}  // namespace

std::string OccupancyGridOptions::validate() const {
  if (!(resolution > 0.0)) return "resolution must be > 0";
  if (!(max_range > 0.0)) return "max_range must be > 0";
  if (!(hit_log_odds > 0.0)) return "hit_log_odds must be > 0";
  if (!(miss_log_odds < 0.0)) return "miss_log_odds must be < 0";
  if (!(clamp_log_odds > 0.0)) return "clamp_log_odds must be > 0";
  if (!(free_threshold > 0.0 && free_threshold < occupied_threshold && occupied_threshold < 1.0))
    return "need 0 < free_threshold < occupied_threshold < 1";
  if (!(margin >= 0.0)) return "margin must be >= 0";
  if (!(no_return_free_range >= 0.0)) return "no_return_free_range must be >= 0";
  if (max_cells == 0) return "max_cells must be > 0";
  return "";
}

OccupancyGrid buildOccupancyGrid(const std::vector<const Scan*>& scans, const std::vector<Pose2>& poses,
                                 const OccupancyGridOptions& options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("occupancy grid options: " + error);
  if (scans.size() != poses.size()) throw std::invalid_argument("occupancy grid: as many poses as scans needed");
  // Bounds: every pose and every return that will be drawn.
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x;
  auto include = [&](double x, double y) {
    min_x = std::min(min_x, x), max_x = std::max(max_x, x);
    min_y = std::min(min_y, y), max_y = std::max(max_y, y);
  };
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const Pose2& pose = poses[k];
    if (!scans[k] || !std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta)) continue;
    include(pose.x, pose.y);
    const Scan& scan = *scans[k];
    for (std::size_t i = 0; i < scan.size() && i < scan.bearings.size(); ++i) {
      const double r = scan.ranges[i];
      if (!(r > 0.0 && r < options.max_range) || !std::isfinite(scan.bearings[i])) continue;
      const double angle = pose.theta + scan.bearings[i];
      include(pose.x + r * std::cos(angle), pose.y + r * std::sin(angle));
    }
  }
  OccupancyGrid grid;
  grid.resolution = options.resolution;
  if (!(min_x <= max_x)) return grid;  // nothing observed
  grid.origin_x = std::floor((min_x - options.margin) / options.resolution) * options.resolution;
  grid.origin_y = std::floor((min_y - options.margin) / options.resolution) * options.resolution;
  const double cols = std::ceil((max_x + options.margin - grid.origin_x) / options.resolution) + 1.0;
  const double rows = std::ceil((max_y + options.margin - grid.origin_y) / options.resolution) + 1.0;
  if (cols * rows > double(options.max_cells))
    throw std::invalid_argument("occupancy grid: " + std::to_string(long(cols)) + " x " + std::to_string(long(rows)) +
                                " cells exceed max_cells; use a coarser resolution");
  grid.width = int(cols);
  grid.height = int(rows);
  std::vector<float> log_odds(std::size_t(grid.width) * std::size_t(grid.height), 0.0f);
  const float hit = float(options.hit_log_odds), miss = float(options.miss_log_odds), clamp = float(options.clamp_log_odds);
  auto cellOf = [&](double v, double origin) { return int(std::floor((v - origin) / options.resolution)); };
  auto inside = [&](int c, int r) { return c >= 0 && r >= 0 && c < grid.width && r < grid.height; };
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const Pose2& pose = poses[k];
    if (!scans[k] || !std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta)) continue;
    const Scan& scan = *scans[k];
    const int c0 = cellOf(pose.x, grid.origin_x), r0 = cellOf(pose.y, grid.origin_y);
    for (std::size_t i = 0; i < scan.size() && i < scan.bearings.size(); ++i) {
      const double r = scan.ranges[i];
      // REP-117: +inf (and anything at or beyond max_range) is no return: free space up to
      // no_return_free_range at most; NaN, -inf, zero and negative ranges say nothing.
      if (!(r > 0.0) || std::isnan(scan.bearings[i]) || std::isinf(scan.bearings[i])) continue;
      const bool returned = r < options.max_range;
      if (!returned && !(options.no_return_free_range > 0.0)) continue;
      const double length = returned ? r : std::min(options.no_return_free_range, options.max_range);
      const double angle = pose.theta + scan.bearings[i];
      const int c1 = cellOf(pose.x + length * std::cos(angle), grid.origin_x);
      const int r1 = cellOf(pose.y + length * std::sin(angle), grid.origin_y);
      traverse(c0, r0, c1, r1, [&](int c, int row) {
        if (!inside(c, row)) return;
        float& cell = log_odds[std::size_t(row) * std::size_t(grid.width) + std::size_t(c)];
        cell = std::max(-clamp, cell + miss);
      });
      if (returned && inside(c1, r1)) {
        float& cell = log_odds[std::size_t(r1) * std::size_t(grid.width) + std::size_t(c1)];
        cell = std::min(clamp, cell + hit);
      }
    }
  }
  grid.cells.assign(log_odds.size(), -1);
  for (std::size_t i = 0; i < log_odds.size(); ++i)
    if (log_odds[i] != 0.0f) grid.cells[i] = std::int8_t(std::lround(100.0 / (1.0 + std::exp(-double(log_odds[i])))));
  return grid;
}

void saveMapFiles(const OccupancyGrid& grid, const std::string& stem, const OccupancyGridOptions& options) {
  std::ostringstream pgm;
  pgm << "P5\n# laser_loop_closure occupancy grid\n" << grid.width << " " << grid.height << "\n255\n";
  std::string pixels(std::size_t(grid.width) * std::size_t(grid.height), char(205));
  for (int row = 0; row < grid.height; ++row)
    for (int col = 0; col < grid.width; ++col) {
      const int value = grid.at(col, row);
      char& pixel = pixels[std::size_t(grid.height - 1 - row) * std::size_t(grid.width) + std::size_t(col)];
      if (value < 0) continue;
      if (value >= options.occupied_threshold * 100.0) pixel = char(0);
      else if (value <= options.free_threshold * 100.0) pixel = char(254);
    }
  pgm << pixels;
  writeFileAtomically(stem + ".pgm", pgm.str());
  std::ostringstream yaml;
  yaml.precision(17);
  yaml << "image: " << baseName(stem) << ".pgm\n"
       << "resolution: " << grid.resolution << "\n"
       << "origin: [" << grid.origin_x << ", " << grid.origin_y << ", 0.0]\n"
       << "negate: 0\n"
       << "occupied_thresh: " << options.occupied_threshold << "\n"
       << "free_thresh: " << options.free_threshold << "\n";
  writeFileAtomically(stem + ".yaml", yaml.str());
}

OccupancyGrid loadMapFiles(const std::string& yaml_path) {
  OccupancyGrid grid;
  std::string image;
  double occupied = 0.65, free = 0.196;
  try {
    const YAML::Node node = YAML::LoadFile(yaml_path);
    image = node["image"].as<std::string>();
    grid.resolution = node["resolution"].as<double>();
    grid.origin_x = node["origin"][0].as<double>();
    grid.origin_y = node["origin"][1].as<double>();
    if (node["occupied_thresh"]) occupied = node["occupied_thresh"].as<double>();
    if (node["free_thresh"]) free = node["free_thresh"].as<double>();
  } catch (const std::exception& e) {
    throw std::runtime_error(yaml_path + ": not a map file (" + e.what() + ")");
  }
  if (!(grid.resolution > 0.0)) throw std::runtime_error(yaml_path + ": resolution must be > 0");
  const std::string pgm_path = !image.empty() && image[0] == '/' ? image : directoryOf(yaml_path) + image;
  std::ifstream in(pgm_path, std::ios::binary);
  if (!in) throw std::runtime_error(pgm_path + ": cannot open");
  std::string magic;
  in >> magic;
  auto nextNumber = [&](const char* what) {
    in >> std::ws;
    while (in.peek() == '#') {
      std::string comment;
      std::getline(in, comment);
      in >> std::ws;
    }
    long value = -1;
    if (!(in >> value) || value <= 0) throw std::runtime_error(pgm_path + ": bad " + std::string(what));
    return value;
  };
  if (magic != "P5") throw std::runtime_error(pgm_path + ": not a binary PGM (P5)");
  const long width = nextNumber("width"), height = nextNumber("height"), maximum = nextNumber("maximum");
  if (maximum != 255 || width > 100000 || height > 100000) throw std::runtime_error(pgm_path + ": unsupported PGM header");
  in.get();  // the single whitespace after the header
  std::string pixels(std::size_t(width * height), '\0');
  if (!in.read(&pixels[0], std::streamsize(pixels.size()))) throw std::runtime_error(pgm_path + ": truncated pixels");
  grid.width = int(width);
  grid.height = int(height);
  grid.cells.assign(pixels.size(), -1);
  for (long row = 0; row < height; ++row)
    for (long col = 0; col < width; ++col) {
      const double p = (255.0 - double(static_cast<unsigned char>(pixels[std::size_t((height - 1 - row) * width + col)]))) / 255.0;
      std::int8_t& cell = grid.cells[std::size_t(row * width + col)];
      if (p > occupied) cell = 100;
      else if (p < free) cell = 0;
    }
  return grid;
}

}  // namespace llc
