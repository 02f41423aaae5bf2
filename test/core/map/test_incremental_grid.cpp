// The incremental grid against the grid rebuilt from scratch (buildOccupancyGrid), by hand-worked
// cells, and with bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "laser_loop_closure/core/map/incremental_grid.hpp"
#include "../synthetic_room.hpp"

namespace {

using llc::CellBox;
using llc::IncrementalOccupancyGrid;
using llc::Pose2;
using Scans = std::vector<std::shared_ptr<const llc::CompactScan>>;

std::shared_ptr<const llc::CompactScan> roomScan(const Pose2& pose, std::uint64_t seed) {
  return std::make_shared<const llc::CompactScan>(llc_test::scanAt(llc_test::room(), pose, 360, 0.01, seed));
}

/// The box of a grid built from scratch, in the map's cells.
CellBox boxOf(const llc::OccupancyGrid& grid) {
  return {std::lround(grid.origin_x / grid.resolution), std::lround(grid.origin_y / grid.resolution), grid.width, grid.height};
}

/// Every cell of `grid` outside `inner` is unknown, and inside it equals `expected` cell by cell.
void expectSameCells(const IncrementalOccupancyGrid& grid, const llc::OccupancyGrid& expected) {
  const CellBox inner = boxOf(expected);
  const CellBox all = grid.bounds();
  ASSERT_LE(all.col, inner.col);
  ASSERT_LE(all.row, inner.row);
  ASSERT_GE(all.col + all.cols, inner.col + inner.cols);
  ASSERT_GE(all.row + all.rows, inner.row + inner.rows);
  const llc::OccupancyGrid got = grid.region(all);
  std::size_t differing = 0, outside_known = 0, known = 0;
  for (long row = 0; row < all.rows; ++row)
    for (long col = 0; col < all.cols; ++col) {
      const int value = got.at(int(col), int(row));
      const long c = all.col + col - inner.col, r = all.row + row - inner.row;
      if (c < 0 || r < 0 || c >= inner.cols || r >= inner.rows) {
        outside_known += value != -1;
        continue;
      }
      known += value != -1;
      differing += value != expected.at(int(c), int(r));
    }
  EXPECT_EQ(differing, 0u);
  EXPECT_EQ(outside_known, 0u);
  EXPECT_GT(known, 1000u);
}

llc::OccupancyGrid rebuilt(const Scans& scans, const std::vector<Pose2>& poses, const llc::OccupancyGridOptions& options) {
  std::vector<llc::Scan> expanded(scans.size());  // the reference goes the plain scans' way
  std::vector<const llc::Scan*> raw(scans.size(), nullptr);
  for (std::size_t k = 0; k < scans.size(); ++k)
    if (scans[k]) expanded[k] = scans[k]->scan(), raw[k] = &expanded[k];
  return llc::buildOccupancyGrid(raw, poses, options);
}

}  // namespace

TEST(IncrementalOccupancyGrid, MovedAndAddedKeyframesGiveTheGridRebuiltFromScratch) {
  llc::OccupancyGridOptions options;
  IncrementalOccupancyGrid grid(options);
  Scans scans;
  std::vector<Pose2> poses, drawn_at;
  llc::Random random(7);
  for (int step = 0; step < 8; ++step) {
    for (int k = 0; k < 4; ++k) {  // four new keyframes, seen from where they are in the room
      const Pose2 pose{random.uniform(-4.0, 4.0), random.uniform(-2.5, 2.5), random.uniform(-M_PI, M_PI)};
      scans.push_back(roomScan(pose, scans.size() + 1));
      poses.push_back(pose);
      drawn_at.push_back(pose);
    }
    // The graph moves older keyframes: some well beyond the tolerance, some within it.
    for (std::size_t k = 0; k + 4 < poses.size(); ++k) {
      if (random.uniform(0.0, 1.0) < 0.3) {
        poses[k].x += random.uniform(-0.5, 0.5), poses[k].theta += random.uniform(-0.1, 0.1);
      } else if (random.uniform(0.0, 1.0) < 0.2) {
        poses[k].x += 0.01;  // 1 cm: not redrawn
      }
    }
    llc::GridUpdateResult result = grid.update(scans, poses, 5);
    while (result.waiting > 0) result = grid.update(scans, poses, 5);
    // Each keyframe stays where it was drawn unless it moved beyond redraw_distance since.
    for (std::size_t k = 0; k < poses.size(); ++k)
      if (std::hypot(poses[k].x - drawn_at[k].x, poses[k].y - drawn_at[k].y) > options.redraw_distance ||
          std::abs(poses[k].theta - drawn_at[k].theta) > options.redraw_angle)
        drawn_at[k] = poses[k];
    SCOPED_TRACE("step " + std::to_string(step));
    expectSameCells(grid, rebuilt(scans, drawn_at, options));
    EXPECT_EQ(grid.drawnKeyframes(), scans.size());
  }
  // Fewer keyframes given (a session loaded in their place): the rest are taken out exactly.
  scans.resize(3), poses.resize(3), drawn_at.resize(3);
  const llc::GridUpdateResult result = grid.update(scans, poses);
  EXPECT_EQ(result.removed, 29u);
  expectSameCells(grid, rebuilt(scans, drawn_at, options));
}

TEST(IncrementalOccupancyGrid, OneKeyframeMovedHandWorked) {
  llc::OccupancyGridOptions options;
  options.grow_step = 0.0;
  IncrementalOccupancyGrid grid(options);
  // Four 1 m beams along the axes from the origin; 0.1 m cells.
  const Scans scans{std::make_shared<const llc::CompactScan>(llc_test::ringScan({1.0, 1.0, 1.0, 1.0}))};
  llc::GridUpdateResult result = grid.update(scans, {Pose2{0.05, 0.05, 0.0}});
  EXPECT_EQ(result.drawn, 1u);
  EXPECT_TRUE(result.bounds_grew);
  ASSERT_FALSE(result.changed.empty());
  auto cell = [&](double x, double y) {
    const CellBox one{long(std::floor(x / 0.1)), long(std::floor(y / 0.1)), 1, 1};
    return int(grid.region(one).cells.at(0));
  };
  EXPECT_EQ(cell(1.05, 0.05), 70);  // a hit: 100 / (1 + e^-0.85)
  EXPECT_EQ(cell(0.55, 0.05), 40);  // crossed: 100 / (1 + e^0.4)
  EXPECT_EQ(cell(0.55, 0.55), -1);
  // Bounds: beam ends in cells -10 (x = -0.95) .. 10 (x = 1.05), 20 cells of margin round them.
  EXPECT_EQ(grid.bounds().col, -10 - 20);
  EXPECT_EQ(grid.bounds().cols, 21 + 40);
  // 3 m along x: the old cells are unknown again, the new ones hit.
  result = grid.update(scans, {Pose2{3.05, 0.05, 0.0}});
  EXPECT_EQ(result.redrawn, 1u);
  EXPECT_EQ(result.drawn, 0u);
  EXPECT_TRUE(result.bounds_grew);
  EXPECT_EQ(cell(1.05, 0.05), -1);
  EXPECT_EQ(cell(0.55, 0.05), -1);
  EXPECT_EQ(cell(4.05, 0.05), 70);
  EXPECT_EQ(cell(3.55, 0.05), 40);
  // Within the tolerance: nothing to do, nothing changed.
  result = grid.update(scans, {Pose2{3.09, 0.05, 0.004}});
  EXPECT_EQ(result.redrawn, 0u);
  EXPECT_TRUE(result.changed.empty());
  EXPECT_FALSE(result.bounds_grew);
  EXPECT_EQ(cell(4.05, 0.05), 70);
  // Another scan at the same index (a keyframe replaced): taken out and the new one drawn.
  const Scans other{std::make_shared<const llc::CompactScan>(llc_test::ringScan({2.0, 2.0, 2.0, 2.0}))};
  result = grid.update(other, {Pose2{3.05, 0.05, 0.0}});
  EXPECT_EQ(result.redrawn, 1u);
  EXPECT_EQ(cell(4.05, 0.05), 40);
  EXPECT_EQ(cell(5.05, 0.05), 70);
}

TEST(IncrementalOccupancyGrid, DrawsNewKeyframesFirstAndAtMostMaxDrawsPerUpdate) {
  IncrementalOccupancyGrid grid(llc::OccupancyGridOptions{});
  Scans scans;
  std::vector<Pose2> poses;
  for (int k = 0; k < 10; ++k) {
    poses.push_back(Pose2{0.5 * k - 2.0, 0.0, 0.0});
    scans.push_back(roomScan(poses.back(), k + 1));
  }
  llc::GridUpdateResult result = grid.update(scans, poses, 4);
  EXPECT_EQ(result.drawn, 4u);
  EXPECT_EQ(result.waiting, 6u);
  poses[0].x += 1.0;  // moved, but the six not drawn yet go first
  result = grid.update(scans, poses, 4);
  EXPECT_EQ(result.drawn, 4u);
  EXPECT_EQ(result.redrawn, 0u);
  EXPECT_EQ(result.waiting, 3u);
  result = grid.update(scans, poses, 4);
  EXPECT_EQ(result.drawn, 2u);
  EXPECT_EQ(result.redrawn, 1u);
  EXPECT_EQ(result.waiting, 0u);
  EXPECT_EQ(grid.update(scans, poses, 4).redrawn, 0u);
}

TEST(IncrementalOccupancyGrid, BadPosesAndScansAreSkippedNotFatal) {
  llc::OccupancyGridOptions options;
  options.max_cells = 1000000;  // 100 x 100 m
  IncrementalOccupancyGrid grid(options);
  const auto scan = roomScan(Pose2{}, 1);
  const double nan = std::nan("");
  const Scans scans{scan, nullptr, scan, scan};
  const std::vector<Pose2> poses{Pose2{}, Pose2{}, Pose2{nan, 0, 0}, Pose2{1e300, 0, 0}};
  const llc::GridUpdateResult result = grid.update(scans, poses);
  EXPECT_EQ(result.drawn, 1u);
  EXPECT_EQ(result.refused, 1u);
  EXPECT_EQ(result.too_large, 1u);
  EXPECT_LE(grid.bounds().cells(), 1e6);
  EXPECT_THROW(grid.update(scans, {}), std::invalid_argument);
  options.redraw_distance = 0.0;
  EXPECT_THROW(IncrementalOccupancyGrid{options}, std::invalid_argument);
  options = {};
  options.clamp_log_odds = 1e9;
  EXPECT_THROW(IncrementalOccupancyGrid{options}, std::invalid_argument);
}

TEST(IncrementalOccupancyGrid, BoundsGrowInStepsAndChangesAreTheTilesTouched) {
  llc::OccupancyGridOptions options;
  options.grow_step = 20.0;
  IncrementalOccupancyGrid grid(options);
  const Scans scans{std::make_shared<const llc::CompactScan>(llc_test::ringScan({1.0, 1.0, 1.0, 1.0}))};
  EXPECT_TRUE(grid.update(scans, {Pose2{}}).bounds_grew);
  // 1 m + 2 m margin + 20 m step each way, in cells of 0.1 m.
  EXPECT_GE(grid.bounds().cols, 2 * 230);
  llc::GridUpdateResult result = grid.update(scans, {Pose2{10.0, 0.0, 0.0}});
  EXPECT_FALSE(result.bounds_grew);  // within the step
  // The cells changed lie in the tiles listed: at the old place and the new.
  bool old_place = false, new_place = false;
  for (const CellBox& box : result.changed) {
    EXPECT_EQ(box.rows, std::min<long>(IncrementalOccupancyGrid::kTileCells, box.rows));
    old_place |= box.col <= 0 && 0 < box.col + box.cols;
    new_place |= box.col <= 100 && 100 < box.col + box.cols;
  }
  EXPECT_TRUE(old_place);
  EXPECT_TRUE(new_place);
  EXPECT_TRUE(grid.update(scans, {Pose2{40.0, 0.0, 0.0}}).bounds_grew);
  EXPECT_GT(grid.bytes(), grid.tiles() * sizeof(std::int16_t) * 64 * 64);
}
