#include "laser_loop_closure/core/map/incremental_grid.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {
namespace {

/// Grid cells crossed from (x0, y0) to (x1, y1), end cell excluded (integer DDA, Bresenham).
template <typename Visit>
void traverse(long x0, long y0, long x1, long y1, Visit&& visit) {
  const long dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const long sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  long error = dx + dy;
  while (x0 != x1 || y0 != y1) {
    visit(x0, y0);
    const long twice = 2 * error;
    if (twice >= dy) error += dy, x0 += sx;
    if (twice <= dx) error += dx, y0 += sy;
  }
}

constexpr long kTile = IncrementalOccupancyGrid::kTileCells;

constexpr int kTileShift = 6;  // kTile = 64 = 1 << 6: a cell's tile by an arithmetic shift, floor for negatives too
static_assert(kTile == 1L << kTileShift, "kTileCells must be 1 << kTileShift");
long tileOf(long cell) { return cell >> kTileShift; }
/// A cell's place within its tile.
std::size_t indexInTile(long col, long row) { return std::size_t(((row & (kTile - 1)) << kTileShift) | (col & (kTile - 1))); }

/// Log-odds are kept in steps of 0.01 in 16 bits: exact sums up to +-327 (385 hits of 0.85),
/// saturating beyond (a cell that sure stays sure when a few keyframes are taken out).
constexpr double kLogOddsStep = 0.01;
constexpr std::int32_t kMostLogOdds = 32767;

std::uint64_t tileKey(long tile_col, long tile_row) {
  return (std::uint64_t(std::uint32_t(tile_col)) << 32) | std::uint64_t(std::uint32_t(tile_row));
}
long tileColOf(std::uint64_t key) { return long(std::int32_t(std::uint32_t(key >> 32))); }
long tileRowOf(std::uint64_t key) { return long(std::int32_t(std::uint32_t(key))); }

CellBox unite(const CellBox& a, const CellBox& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  const long col = std::min(a.col, b.col), row = std::min(a.row, b.row);
  return {col, row, std::max(a.col + a.cols, b.col + b.cols) - col, std::max(a.row + a.rows, b.row + b.rows) - row};
}
CellBox grown(const CellBox& box, long cells) {
  return box.empty() ? box : CellBox{box.col - cells, box.row - cells, box.cols + 2 * cells, box.rows + 2 * cells};
}
bool contains(const CellBox& outer, const CellBox& inner) {
  return !outer.empty() && inner.col >= outer.col && inner.row >= outer.row &&
         inner.col + inner.cols <= outer.col + outer.cols && inner.row + inner.rows <= outer.row + outer.rows;
}
CellBox intersect(const CellBox& a, const CellBox& b) {
  const long col = std::max(a.col, b.col), row = std::max(a.row, b.row);
  return {col, row, std::min(a.col + a.cols, b.col + b.cols) - col, std::min(a.row + a.rows, b.row + b.rows) - row};
}

bool finite(const Pose2& pose) { return std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta); }

}  // namespace

struct IncrementalOccupancyGrid::Tile {
  std::array<std::int16_t, kTile * kTile> sum{};  ///< log-odds in steps of kLogOddsStep, unclamped
  std::uint32_t epoch = 0;                          ///< the last update that changed it
};

IncrementalOccupancyGrid::IncrementalOccupancyGrid(const OccupancyGridOptions& options) : options_(options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("occupancy grid options: " + error);
  hit_ = std::int32_t(std::lround(options.hit_log_odds / kLogOddsStep));
  miss_ = std::int32_t(std::lround(options.miss_log_odds / kLogOddsStep));
  clamp_ = std::int32_t(std::lround(options.clamp_log_odds / kLogOddsStep));
  if (hit_ == 0 || miss_ == 0 || clamp_ == 0)
    throw std::invalid_argument("occupancy grid options: hit, miss and clamp log-odds must be at least 0.01");
  percent_.resize(std::size_t(2 * clamp_ + 1));
  for (std::int32_t v = -clamp_; v <= clamp_; ++v)
    percent_[std::size_t(v + clamp_)] = std::int8_t(std::lround(100.0 / (1.0 + std::exp(-double(v) * kLogOddsStep))));
}

IncrementalOccupancyGrid::~IncrementalOccupancyGrid() = default;
IncrementalOccupancyGrid::IncrementalOccupancyGrid(IncrementalOccupancyGrid&&) noexcept = default;
IncrementalOccupancyGrid& IncrementalOccupancyGrid::operator=(IncrementalOccupancyGrid&&) noexcept = default;

void IncrementalOccupancyGrid::add(long col, long row, std::int32_t delta) {
  std::int16_t& cell = *cellFor(col, row);
  cell = std::int16_t(std::clamp(std::int32_t(cell) + delta, -kMostLogOdds, kMostLogOdds));
}

std::int16_t* IncrementalOccupancyGrid::cellFor(long col, long row) {
  const long tile_col = tileOf(col), tile_row = tileOf(row);
  const std::uint64_t key = tileKey(tile_col, tile_row);
  if (key == last_key_ && last_tile_) return &last_tile_->sum[indexInTile(col, row)];
  std::unique_ptr<Tile>& held = tiles_[key];
  if (!held) held = std::make_unique<Tile>();
  Tile* tile = held.get();
  if (tile->epoch != epoch_) {
    tile->epoch = epoch_;
    touched_.push_back(key);
  }
  last_key_ = key, last_tile_ = tile;
  return &tile->sum[indexInTile(col, row)];
}

void IncrementalOccupancyGrid::draw(const Scan& scan, const Pose2& pose, int sign) {
  const double resolution = options_.resolution;
  auto cellOf = [&](double v) { return long(std::floor(v / resolution)); };
  const long c0 = cellOf(pose.x), r0 = cellOf(pose.y);
  long min_col = c0, max_col = c0, min_row = r0, max_row = r0;
  const std::int32_t hit = sign * hit_, miss = sign * miss_;
  for (std::size_t i = 0; i < scan.size() && i < scan.bearings.size(); ++i) {
    const double r = scan.ranges[i];
    // REP-117: +inf (and anything at or beyond max_range) is no return: free space up to
    // no_return_free_range at most; NaN, -inf, zero and negative ranges say nothing.
    if (!(r > 0.0) || !std::isfinite(scan.bearings[i])) continue;
    const bool returned = r < options_.max_range;
    if (!returned && !(options_.no_return_free_range > 0.0)) continue;
    const double length = returned ? r : std::min(options_.no_return_free_range, options_.max_range);
    const double angle = pose.theta + scan.bearings[i];
    const long c1 = cellOf(pose.x + length * std::cos(angle)), r1 = cellOf(pose.y + length * std::sin(angle));
    traverse(c0, r0, c1, r1, [&](long c, long row) { add(c, row, miss); });
    if (returned) add(c1, r1, hit);
    min_col = std::min(min_col, c1), max_col = std::max(max_col, c1);
    min_row = std::min(min_row, r1), max_row = std::max(max_row, r1);
  }
  if (sign > 0) observed_ = unite(observed_, {min_col, min_row, max_col - min_col + 1, max_row - min_row + 1});
}

bool IncrementalOccupancyGrid::fits(const Pose2& pose) const {
  // Every cell a keyframe draws lies within max_range of its pose: checked in double before any
  // cell index is formed, so a pose at 1e300 m is refused instead of overflowing.
  const double resolution = options_.resolution, reach = options_.max_range + options_.margin;
  double min_x = pose.x - reach, max_x = pose.x + reach, min_y = pose.y - reach, max_y = pose.y + reach;
  const CellBox known = unite(bounds_, observed_);  // bounds_ lags behind within an update
  if (!known.empty()) {
    min_x = std::min(min_x, double(known.col) * resolution - options_.margin);
    max_x = std::max(max_x, double(known.col + known.cols) * resolution + options_.margin);
    min_y = std::min(min_y, double(known.row) * resolution - options_.margin);
    max_y = std::max(max_y, double(known.row + known.rows) * resolution + options_.margin);
  }
  return ((max_x - min_x) / resolution + 1.0) * ((max_y - min_y) / resolution + 1.0) <= double(options_.max_cells);
}

void IncrementalOccupancyGrid::growBounds(const CellBox& needed, double step_cells, GridUpdateResult* result) {
  if (needed.empty() || contains(bounds_, needed)) return;
  // Each side that is too short grows by the step, or by a quarter of the map's size when that
  // is more: a map that keeps growing is sent whole a number of times that grows as a logarithm.
  if (step_cells > 0.0 && !bounds_.empty()) step_cells = std::max(step_cells, 0.25 * double(std::max(bounds_.cols, bounds_.rows)));
  const long step = long(std::ceil(step_cells));
  CellBox next = needed;
  if (!bounds_.empty()) {
    const long left = needed.col < bounds_.col ? needed.col - step : bounds_.col;
    const long bottom = needed.row < bounds_.row ? needed.row - step : bounds_.row;
    const long right = needed.col + needed.cols > bounds_.col + bounds_.cols ? needed.col + needed.cols + step : bounds_.col + bounds_.cols;
    const long top = needed.row + needed.rows > bounds_.row + bounds_.rows ? needed.row + needed.rows + step : bounds_.row + bounds_.rows;
    next = {left, bottom, right - left, top - bottom};
  } else {
    next = grown(needed, step);
  }
  if (next.cells() > double(options_.max_cells)) next = unite(bounds_, needed);  // no room to spare
  bounds_ = next;
  result->bounds_grew = true;
}

GridUpdateResult IncrementalOccupancyGrid::update(const std::vector<std::shared_ptr<const CompactScan>>& scans,
                                                  const std::vector<Pose2>& poses, std::size_t max_draws) {
  if (scans.size() != poses.size()) throw std::invalid_argument("occupancy grid: as many poses as scans needed");
  GridUpdateResult result;
  touched_.clear();
  ++epoch_;
  last_tile_ = nullptr;  // its tile must be marked touched in this update again
  for (std::size_t k = drawn_.size(); k-- > scans.size();) {
    if (drawn_[k].scan) draw(drawn_[k].scan->scan(), drawn_[k].pose, -1), ++result.removed;
  }
  drawn_.resize(scans.size());
  // New keyframes (and those given another scan) first, oldest first; then the most moved.
  std::vector<std::pair<double, std::size_t>> due;
  const double kNew = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < scans.size(); ++k) {
    if (!scans[k]) continue;
    const Drawn& was = drawn_[k];
    if (was.scan != scans[k]) {
      due.emplace_back(kNew, k);
      continue;
    }
    if (!finite(poses[k])) continue;
    const double moved = std::max(std::hypot(poses[k].x - was.pose.x, poses[k].y - was.pose.y) / options_.redraw_distance,
                                  std::abs(normalizeAngle(poses[k].theta - was.pose.theta)) / options_.redraw_angle);
    if (moved > 1.0) due.emplace_back(moved, k);
  }
  std::stable_sort(due.begin(), due.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::size_t draws = 0;
  for (const auto& [priority, k] : due) {
    if (draws == max_draws) {
      ++result.waiting;
      continue;
    }
    if (!finite(poses[k])) {
      ++result.refused;
      continue;
    }
    if (!fits(poses[k])) {
      ++result.too_large;
      continue;
    }
    Drawn& was = drawn_[k];
    const Scan scan = scans[k]->scan();  // read once (a packed scan is unpacked) for both draws
    if (was.scan) draw(was.scan == scans[k] ? scan : was.scan->scan(), was.pose, -1), ++result.redrawn;
    else ++result.drawn;
    draw(scan, poses[k], +1);
    was = {scans[k], poses[k]};
    ++draws;
  }
  const long margin_cells = long(std::ceil(options_.margin / options_.resolution - 1e-9));
  growBounds(grown(observed_, margin_cells), options_.grow_step / options_.resolution, &result);
  // Changed tiles, clipped to the bounds, merged into runs along each row of tiles.
  std::vector<std::uint64_t>& keys = touched_;
  std::sort(keys.begin(), keys.end(), [](std::uint64_t a, std::uint64_t b) {
    return std::make_pair(tileRowOf(a), tileColOf(a)) < std::make_pair(tileRowOf(b), tileColOf(b));
  });
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i + 1;
    while (j < keys.size() && tileRowOf(keys[j]) == tileRowOf(keys[i]) && tileColOf(keys[j]) == tileColOf(keys[j - 1]) + 1) ++j;
    const CellBox run{tileColOf(keys[i]) * kTile, tileRowOf(keys[i]) * kTile, long(j - i) * kTile, kTile};
    const CellBox clipped = intersect(run, bounds_);
    if (!clipped.empty()) result.changed.push_back(clipped);
    i = j;
  }
  return result;
}

OccupancyGrid IncrementalOccupancyGrid::region(const CellBox& box) const {
  OccupancyGrid grid;
  grid.resolution = options_.resolution;
  if (box.empty()) return grid;
  grid.origin_x = double(box.col) * options_.resolution;
  grid.origin_y = double(box.row) * options_.resolution;
  grid.width = int(box.cols);
  grid.height = int(box.rows);
  grid.cells.assign(std::size_t(box.cols) * std::size_t(box.rows), -1);
  for (long tile_row = tileOf(box.row); tile_row * kTile < box.row + box.rows; ++tile_row)
    for (long tile_col = tileOf(box.col); tile_col * kTile < box.col + box.cols; ++tile_col) {
      const auto found = tiles_.find(tileKey(tile_col, tile_row));
      if (found == tiles_.end()) continue;
      const CellBox part = intersect(box, {tile_col * kTile, tile_row * kTile, kTile, kTile});
      for (long row = part.row; row < part.row + part.rows; ++row)
        for (long col = part.col; col < part.col + part.cols; ++col) {
          const std::int32_t v = found->second->sum[indexInTile(col, row)];
          if (v == 0) continue;  // never seen (or hits and misses that cancel exactly)
          grid.cells[std::size_t(row - box.row) * std::size_t(box.cols) + std::size_t(col - box.col)] =
              percent_[std::size_t(std::clamp(v, -clamp_, clamp_) + clamp_)];
        }
    }
  return grid;
}

std::size_t IncrementalOccupancyGrid::bytes() const {
  const std::size_t per_tile = sizeof(Tile) + sizeof(std::unique_ptr<Tile>) + sizeof(std::uint64_t) + 2 * sizeof(void*);
  return tiles_.size() * per_tile + tiles_.bucket_count() * sizeof(void*) + drawn_.capacity() * sizeof(Drawn) +
         percent_.size();
}

std::size_t IncrementalOccupancyGrid::drawnKeyframes() const {
  return std::size_t(std::count_if(drawn_.begin(), drawn_.end(), [](const Drawn& d) { return bool(d.scan); }));
}

}  // namespace llc
