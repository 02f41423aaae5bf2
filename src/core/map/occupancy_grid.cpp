#include "laser_loop_closure/core/map/occupancy_grid.hpp"

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/map/incremental_grid.hpp"

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
  if (!(redraw_distance > 0.0) || !(redraw_angle > 0.0)) return "redraw_distance and redraw_angle must be > 0";
  if (max_draws_per_update < 1) return "max_draws_per_update must be at least 1";
  if (!(grow_step >= 0.0)) return "grow_step must be >= 0";
  if (!(hit_log_odds <= 100.0 && miss_log_odds >= -100.0 && clamp_log_odds <= 100.0))
    return "|log-odds| above 100 (a probability of 1 - 1e-43) mean nothing more";
  return "";
}

OccupancyGrid buildOccupancyGrid(const std::vector<const Scan*>& scans, const std::vector<Pose2>& poses,
                                 const OccupancyGridOptions& options) {
  std::vector<std::shared_ptr<const CompactScan>> compact;
  compact.reserve(scans.size());
  const CompactScan* before = nullptr;  // bearings are shared where the same
  for (const Scan* scan : scans) {
    compact.push_back(scan ? std::make_shared<const CompactScan>(*scan, before) : nullptr);
    if (scan) before = compact.back().get();
  }
  return buildOccupancyGrid(compact, poses, options);
}

OccupancyGrid buildOccupancyGrid(const std::vector<std::shared_ptr<const CompactScan>>& scans,
                                 const std::vector<Pose2>& poses, const OccupancyGridOptions& options) {
  if (scans.size() != poses.size()) throw std::invalid_argument("occupancy grid: as many poses as scans needed");
  OccupancyGridOptions exact = options;
  exact.grow_step = 0.0;  // bounds: what was observed and the margin
  IncrementalOccupancyGrid grid(exact);
  const GridUpdateResult drawn = grid.update(scans, poses);
  if (drawn.too_large > 0 || grid.bounds().cells() > double(options.max_cells))
    throw std::invalid_argument("occupancy grid: more cells than max_cells (" + std::to_string(options.max_cells) +
                                "); use a coarser resolution");
  return grid.region(grid.bounds());
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
