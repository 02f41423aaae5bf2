// A session at bounded size (slam/session_pruning): two laps of one square keep one keyframe
// per place and heading, the newest or the oldest, and what is left restores, saves and loads.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/session_pruning.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "../test_util.hpp"

namespace {

using llc::Pose2;

/// Two laps (robot 0, then robot 1) of an 8 m square turned by 0.3 rad, a keyframe per metre,
/// odometry between consecutive keyframes and a loop from each keyframe of lap 2 to lap 1's.
llc::SlamSession twoLaps() {
  llc::SlamSession s;
  const Eigen::Matrix3d information = Eigen::Vector3d(100.0, 400.0, 900.0).asDiagonal();
  Pose2 pose{0.7, 0.3, 0.3};  // off the cells' edges, where rounding would split a place
  const std::size_t per_lap = 32;
  for (std::size_t k = 0; k < 2 * per_lap; ++k) {
    llc::Keyframe key;
    key.scan_index = k;
    key.stamp = double(k);
    key.scan = llc_test::ringScan({1.0, 2.0, 3.0});
    s.keyframes.push_back(key);
    s.features.push_back({double(k % per_lap), 1.0});
    s.robots.push_back(k < per_lap ? 0 : 1);
    s.poses.push_back(pose);
    const Pose2 step{1.0, 0.0, (k + 1) % 8 == 0 ? M_PI / 2 : 0.0};
    if (k + 1 < 2 * per_lap) s.constraints.push_back({k, k + 1, step, information});
    pose = llc::compose(pose, step);
  }
  for (std::size_t k = per_lap; k < 2 * per_lap; ++k) {
    s.constraints.push_back({k - per_lap, k, Pose2{0.0, 0.0, 0.0}, information});
    llc::LoopRecord record;
    record.loop.from = k - per_lap;
    record.loop.to = k;
    record.applied = true;
    s.loops.push_back(record);
  }
  return s;
}

TEST(SessionPruning, TwoLapsKeepTheNewestKeyframeOfEachPlaceAndHeading) {
  const llc::SlamSession before = twoLaps();
  ASSERT_EQ(before.validate(), "");
  llc::SessionPruningOptions newest;
  newest.keep_newest = true;
  llc::SessionPruningResult r;
  const llc::SlamSession after = llc::pruneSession(before, newest, &r);
  ASSERT_EQ(after.validate(), "");
  EXPECT_EQ(r.keyframes_before, 64u);
  EXPECT_EQ(r.keyframes_after, after.keyframes.size());
  EXPECT_EQ(r.keyframes_after, r.places);  // one per place and heading (keyframe 0 fills its own)
  EXPECT_LT(r.keyframes_after, 32u);           // lap 1 gone, and lap 2's keyframes sharing a place
  EXPECT_EQ(r.kept_unfactorizable, 0u);
  // The newest were kept: every kept keyframe but the anchor is lap 2's (robot 1).
  EXPECT_EQ(after.robots.front(), 0u);
  std::set<std::tuple<long, long, long>> places;
  for (std::size_t i = 0; i < after.keyframes.size(); ++i) {
    if (i > 0) EXPECT_EQ(after.robots[i], 1u);
    if (i > 0) EXPECT_GE(after.keyframes[i].scan_index, 32u);
    const Pose2& p = after.poses[i];
    const long sector = (long(std::floor(llc::normalizeAngle(p.theta) / (2 * M_PI) * 4 + 0.5)) + 4) % 4;
    EXPECT_TRUE(places.insert({long(std::floor(p.x / 2.0 + 0.5)), long(std::floor(p.y / 2.0 + 0.5)), sector}).second)
        << "two keyframes kept in one place";
  }
  // Loop records name kept keyframes only, renumbered: of lap 1 only keyframe 0 is left.
  EXPECT_EQ(after.loops.size() + r.loops_dropped, before.loops.size());
  EXPECT_LE(after.loops.size(), 1u);
  for (const llc::LoopRecord& record : after.loops) {
    EXPECT_EQ(record.loop.from, 0u);
    EXPECT_EQ(after.keyframes[record.loop.to].scan_index, 32u);
  }
  // It restores into a back end, solved where it was (the laps agree exactly), and round-trips.
  llc::SlamBackEnd back;
  ASSERT_EQ(back.restore(after), "");
  for (std::size_t i = 0; i < after.poses.size(); ++i) {
    EXPECT_NEAR(back.poses()[i].x, after.poses[i].x, 1e-3);
    EXPECT_NEAR(back.poses()[i].y, after.poses[i].y, 1e-3);
  }
  llc_test::TempDir dir;
  const std::string path = dir.file("pruned.llcsession");
  llc::saveSession(after, path);
  const llc::SlamSession loaded = llc::loadSession(path);
  EXPECT_EQ(loaded.keyframes.size(), after.keyframes.size());
  EXPECT_EQ(loaded.constraints.size(), after.constraints.size());
  // Pruned again, nothing more goes.
  llc::SessionPruningResult again;
  llc::pruneSession(after, newest, &again);
  EXPECT_EQ(again.keyframes_after, again.keyframes_before);
}

TEST(SessionPruning, KeepingTheOldestKeepsTheFirstLap) {
  const llc::SlamSession before = twoLaps();
  const llc::SessionPruningOptions oldest;  // the default
  llc::SessionPruningResult r;
  const llc::SlamSession after = llc::pruneSession(before, oldest, &r);
  ASSERT_EQ(after.validate(), "");
  EXPECT_EQ(r.keyframes_after, r.places);
  for (std::size_t i = 0; i < after.keyframes.size(); ++i) {
    EXPECT_EQ(after.robots[i], 0u) << "a keyframe of lap 2 kept where lap 1 had one";
    EXPECT_LT(after.keyframes[i].scan_index, 32u);
  }
  // Lap 2's loops went with its keyframes; what they said of lap 1 stays in its constraints.
  EXPECT_TRUE(after.loops.empty());
  EXPECT_GE(after.constraints.size(), after.keyframes.size() - 1);
  llc::SlamBackEnd back;
  EXPECT_EQ(back.restore(after), "");
}

TEST(SessionPruning, ARobotWaveringAboutTheMapsAxisKeepsOneKeyframePerPlace) {
  // Three passes along the map's x axis (heading 0 and pi), a keyframe per metre, each pass
  // wavering by a millimetre across y = 0 and heading 0: places are centred there, so each
  // 2 m of each direction keeps one keyframe, whatever the wobble.
  llc::SlamSession s;
  const Eigen::Matrix3d information = Eigen::Vector3d(100.0, 400.0, 900.0).asDiagonal();
  for (std::size_t pass = 0; pass < 3; ++pass)
    for (std::size_t k = 0; k < 20; ++k) {
      const std::size_t i = s.poses.size();
      const double wobble = (i % 2 ? 1e-3 : -1e-3);
      const bool back = pass == 1;
      s.poses.push_back({back ? 19.0 - double(k) : double(k), wobble, (back ? M_PI : 0.0) + wobble});
      llc::Keyframe key;
      key.scan_index = i, key.stamp = double(i), key.scan = llc_test::ringScan({1.0, 2.0, 3.0});
      s.keyframes.push_back(key);
      s.features.push_back({double(i), 1.0});
      s.robots.push_back(0);
      if (i > 0) s.constraints.push_back({i - 1, i, llc::between(s.poses[i - 1], s.poses[i]), information});
    }
  ASSERT_EQ(s.validate(), "");
  llc::SessionPruningResult r;
  const llc::SlamSession after = llc::pruneSession(s, llc::SessionPruningOptions{}, &r);
  // x = 0 .. 19 in centred 2 m places: 11 places (x -1..1, 1..3, ..., 19..21) each way.
  EXPECT_EQ(r.places, 22u);
  EXPECT_EQ(after.keyframes.size(), 22u);
}

TEST(SessionPruning, KeepingNoneMeansNoPruningAndBadOptionsAreRefused) {
  const llc::SlamSession before = twoLaps();
  llc::SessionPruningOptions off;
  off.keep_per_place = 0;
  llc::SessionPruningResult r;
  const llc::SlamSession same = llc::pruneSession(before, off, &r);
  EXPECT_EQ(same.keyframes.size(), before.keyframes.size());
  EXPECT_EQ(same.constraints.size(), before.constraints.size());
  EXPECT_EQ(same.loops.size(), before.loops.size());
  llc::SessionPruningOptions bad;
  bad.place_size = 0.0;
  EXPECT_THROW(llc::pruneSession(before, bad, nullptr), std::invalid_argument);
  bad = {};
  bad.heading_sectors = 0;
  EXPECT_THROW(llc::pruneSession(before, bad, nullptr), std::invalid_argument);
  llc::SlamSession broken = before;
  broken.poses.pop_back();
  EXPECT_THROW(llc::pruneSession(broken, {}, nullptr), std::invalid_argument);
}

}  // namespace
