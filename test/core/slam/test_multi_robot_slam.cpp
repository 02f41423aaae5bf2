// MultiRobotSlam on a simulated city driven by two robots at once, each in an odometry frame
// of its own with no relative prior: the second joins the first's map only once several of
// its keyframes agree, with no wrong cross-robot loop, and the joined map lies on the truth.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "../test_util.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/slam/multi_robot_slam.hpp"

namespace {

/// The truth of a robot's keyframe (its scan index is the drive's frame).
const llc::Pose2& truthOf(const llc::MultiRobotSlam& slam, const llc::SimDrive& drive, const llc::RobotKeyframe& k) {
  return drive.frames[slam.robot(k.robot).keyframes()[k.keyframe].scan_index].truth;
}

/// The map's keyframe poses and their truths, in map order.
void mapAndTruth(const llc::MultiRobotSlam& slam, const llc::SimDrive& drive, std::vector<llc::Pose2>* map,
                 std::vector<llc::Pose2>* truth) {
  for (std::size_t m = 0; m < slam.map().keyframes().size(); ++m) {
    map->push_back(slam.map().poses()[m]);
    truth->push_back(truthOf(slam, drive, slam.mapKeyframe(m)));
  }
}

struct TwoRobots {
  llc::SimDrive drive = llc_test::simulatedDrive(600.0);
  std::size_t split = 0;  ///< robot 0 drives frames [0, split), robot 1 [split, end)
  llc::MultiRobotSlam slam{llc_test::defaultModel(), 2};
  std::vector<llc::RobotStep> steps[2];
  std::vector<std::size_t> frames[2];
  TwoRobots() {
    split = drive.frames.size() / 2;
    const llc::Pose2 frame_of_robot_1{-250.0, 400.0, 2.5};  // its odometry frame: anywhere
    for (std::size_t i = 0; i < split; ++i) {
      for (std::size_t robot = 0; robot < 2; ++robot) {  // both drive at once
        const std::size_t f = robot == 0 ? i : split + i;
        if (f >= drive.frames.size()) continue;
        const llc::Pose2 odometry = robot == 0 ? drive.frames[f].odometry : llc::compose(frame_of_robot_1, drive.frames[f].odometry);
        steps[robot].push_back(slam.addScan(robot, llc_test::frameScan(drive, drive.frames[f]), f, &odometry));
        frames[robot].push_back(f);
      }
    }
  }
  const llc::Pose2& truthOf(std::size_t robot, std::size_t keyframe) const {
    return ::truthOf(slam, drive, {robot, keyframe});
  }
};

const TwoRobots& twoRobots() {
  static const TwoRobots run;
  return run;
}

TEST(MultiRobotSlam, TheSecondRobotJoinsAndEveryCrossLoopIsRight) {
  const TwoRobots& run = twoRobots();
  ASSERT_TRUE(run.slam.joined(1)) << "robot 1 never joined";
  std::size_t joined_at = 0;
  for (std::size_t k = 0; k < run.steps[1].size(); ++k)
    if (run.steps[1][k].joined_now) joined_at = k;
  std::cout << "robot 1 joined at its scan " << joined_at << " (frame " << run.frames[1][joined_at] << "), after "
            << run.slam.joinedAtPath(1) << " m; cross loops " << run.slam.counters().cross_robot_loops << "\n";
  // Travel (by the truth) from the first keyframe of robot 1 that sees a place robot 0 had
  // mapped by then (within 1 m) to the join.
  const auto& keyframes1 = run.slam.robot(1).keyframes();
  const auto& keyframes0 = run.slam.robot(0).keyframes();
  double path = 0.0, path_at_overlap = -1.0, path_at_join = -1.0;
  for (std::size_t k = 0; k < keyframes1.size(); ++k) {
    const llc::Pose2& t = run.truthOf(1, k);
    if (k > 0) path += std::hypot(t.x - run.truthOf(1, k - 1).x, t.y - run.truthOf(1, k - 1).y);
    for (std::size_t j = 0; j < keyframes0.size() && path_at_overlap < 0.0; ++j) {
      const llc::Pose2& u = run.truthOf(0, j);
      if (keyframes0[j].stamp - keyframes0.front().stamp <= keyframes1[k].stamp - keyframes1.front().stamp &&
          std::hypot(t.x - u.x, t.y - u.y) < 1.0)
        path_at_overlap = path;
    }
    if (path_at_join < 0.0 && keyframes1[k].scan_index >= run.frames[1][joined_at])
      path_at_join = path;
  }
  std::cout << "first overlap after " << path_at_overlap << " m of robot 1's path, joined after " << path_at_join << " m\n";
  ASSERT_GE(path_at_overlap, 0.0);
  EXPECT_LT(path_at_join - path_at_overlap, 5.0) << "joined long after the robots first saw the same place";
  ASSERT_GE(run.slam.crossLoops().size(), 3u);
  EXPECT_GT(run.slam.counters().cross_not_aligned, 0u) << "a joined robot's candidates never met the map's place gate";
  for (const llc::CrossRobotLoop& loop : run.slam.crossLoops()) {
    if (!loop.record.applied) continue;
    const llc::Pose2 truth = llc::between(run.truthOf(loop.from.robot, loop.from.keyframe), run.truthOf(loop.to.robot, loop.to.keyframe));
    const llc::Pose2 e = llc::between(truth, loop.record.loop.pose);
    EXPECT_LT(std::hypot(e.x, e.y), 0.5) << "a wrong cross-robot loop";
    EXPECT_LT(std::abs(e.theta), 0.05);
  }
}

TEST(MultiRobotSlam, TheJoinedMapLiesOnTheTruth) {
  const TwoRobots& run = twoRobots();
  std::vector<llc::Pose2> map, truth;
  mapAndTruth(run.slam, run.drive, &map, &truth);
  ASSERT_EQ(map.size(), run.slam.robot(0).keyframes().size() + run.slam.robot(1).keyframes().size());
  const double rms = llc::alignedRmsError(map, truth);
  std::cout << "joined map: " << map.size() << " keyframes, RMS " << rms << " m\n";
  EXPECT_LT(rms, 0.5);
  // Its session names each keyframe's robot and restores as any map does.
  const llc::SlamSession session = run.slam.session();
  EXPECT_EQ(session.validate(), "");
  ASSERT_EQ(session.robots.size(), map.size());
  for (std::size_t m = 0; m < map.size(); ++m) EXPECT_EQ(session.robots[m], run.slam.mapKeyframe(m).robot) << m;
  llc::SlamPipeline restored(llc_test::defaultModel());
  EXPECT_EQ(restored.restore(session, false), "");
  EXPECT_EQ(restored.keyframes().size(), map.size());
}

TEST(MultiRobotSlam, KeyframesMadeByFrontEndsElsewhereJoinAsTheScansDo) {
  // What the multi-robot back end node does: each robot's own front end (here a pipeline of its
  // own, as a robot's loop_closure nodelet) makes the keyframes and finds its own loops; the
  // map only takes keyframes (scan, features, odometry step) and those loops, after each keyframe.
  const TwoRobots& scans = twoRobots();
  const llc::SimDrive& drive = scans.drive;
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 2);
  std::vector<std::unique_ptr<llc::SlamPipeline>> front_ends;
  for (int robot = 0; robot < 2; ++robot) front_ends.push_back(std::make_unique<llc::SlamPipeline>(llc_test::defaultModel()));
  const llc::Pose2 frame_of_robot_1{-250.0, 400.0, 2.5};
  std::size_t joined_at = 0, own_loops = 0;
  for (std::size_t i = 0; i < scans.split; ++i) {
    for (std::size_t robot = 0; robot < 2; ++robot) {
      const std::size_t f = robot == 0 ? i : scans.split + i;
      if (f >= drive.frames.size()) continue;
      const llc::Pose2 odometry = robot == 0 ? drive.frames[f].odometry : llc::compose(frame_of_robot_1, drive.frames[f].odometry);
      const llc::SlamStepResult made = front_ends[robot]->addScan(llc_test::frameScan(drive, drive.frames[f]), f, &odometry);
      if (!made.keyframe) continue;
      const std::size_t k = made.keyframe_index;
      const llc::RobotStep step = slam.addKeyframe(robot, front_ends[robot]->keyframes()[k],
                                                   front_ends[robot]->detector().features(k), made.odometry);
      EXPECT_EQ(step.slam.keyframe_index, k);
      if (step.joined_now) joined_at = k;
      for (const llc::LoopClosure& loop : made.loops.aligned)
        if (loop.accepted) slam.addLoop(robot, loop), ++own_loops;
    }
  }
  ASSERT_TRUE(slam.joined(1));
  std::size_t scans_joined_at = 0;
  for (std::size_t k = 0, keyframe = 0; k < scans.steps[1].size(); ++k)
    if (scans.steps[1][k].slam.keyframe) {
      if (scans.steps[1][k].joined_now) scans_joined_at = keyframe;
      ++keyframe;
    }
  std::cout << "robot 1 joined at keyframe " << joined_at << " (from scans: " << scans_joined_at << "), own loops "
            << own_loops << ", cross loops " << slam.counters().cross_robot_loops << " (from scans: "
            << scans.slam.counters().cross_robot_loops << ")\n";
  // The same classes on the same keyframes (the stores calibrated alike; this drive's robots
  // close no loop of their own, so no order of own loops can differ): the same map.
  EXPECT_EQ(joined_at, scans_joined_at);
  EXPECT_EQ(slam.counters().cross_robot_loops, scans.slam.counters().cross_robot_loops);
  ASSERT_EQ(slam.robot(1).keyframes().size(), scans.slam.robot(1).keyframes().size());
  for (const llc::CrossRobotLoop& loop : slam.crossLoops()) {
    if (!loop.record.applied) continue;
    const llc::Pose2 truth = llc::between(truthOf(slam, drive, loop.from), truthOf(slam, drive, loop.to));
    const llc::Pose2 e = llc::between(truth, loop.record.loop.pose);
    EXPECT_LT(std::hypot(e.x, e.y), 0.5) << "a wrong cross-robot loop";
  }
  std::vector<llc::Pose2> map, truth, scans_map, scans_truth;
  mapAndTruth(slam, drive, &map, &truth);
  mapAndTruth(scans.slam, drive, &scans_map, &scans_truth);
  ASSERT_EQ(map.size(), scans_map.size());
  const double rms = llc::alignedRmsError(map, truth), scans_rms = llc::alignedRmsError(scans_map, scans_truth);
  std::cout << "map RMS " << rms << " m (from scans: " << scans_rms << " m)\n";
  EXPECT_NEAR(rms, scans_rms, 1e-6);
  // A loop naming a keyframe the robot never sent is refused, not fatal; an unknown robot throws.
  const llc::LoopRecord bad = slam.addLoop(1, llc::LoopClosure{});
  llc::LoopClosure beyond;
  beyond.from = 0, beyond.to = 100000, beyond.accepted = true;
  EXPECT_FALSE(slam.addLoop(1, beyond).applied);
  EXPECT_FALSE(bad.applied);
  EXPECT_THROW(slam.addLoop(2, beyond), std::out_of_range);
}

TEST(MultiRobotSlam, ARobotJoinsYesterdaysMapOfTheFleet) {
  // Yesterday: robot 0 mapped the first half, saved as a session with its robot named 5.
  const TwoRobots& today = twoRobots();
  const llc::SimDrive& drive = today.drive;
  llc::MultiRobotSlam yesterday(llc_test::defaultModel(), 1);
  for (std::size_t f = 0; f < today.split; ++f)
    yesterday.addScan(0, llc_test::frameScan(drive, drive.frames[f]), f, &drive.frames[f].odometry);
  llc::SlamSession saved = yesterday.session();
  saved.robots.assign(saved.keyframes.size(), 5);
  // Today: the map is robot 0 (no scans of its own); robot 1 drives the second half in an
  // odometry frame of its own and joins it with no pose prior.
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 2, {}, {}, &saved);
  ASSERT_TRUE(slam.hasSavedMap());
  ASSERT_EQ(slam.map().keyframes().size(), saved.keyframes.size());
  EXPECT_NEAR(slam.map().poses().back().x, saved.poses.back().x, 1e-6);
  const llc::Pose2 frame_of_robot_1{-250.0, 400.0, 2.5};
  for (std::size_t f = today.split; f < drive.frames.size(); ++f) {
    const llc::Pose2 odometry = llc::compose(frame_of_robot_1, drive.frames[f].odometry);
    slam.addScan(1, llc_test::frameScan(drive, drive.frames[f]), f, &odometry);
  }
  ASSERT_TRUE(slam.joined(1)) << "robot 1 never joined the saved map";
  std::cout << "robot 1 joined the saved map after " << slam.joinedAtPath(1) << " m; cross loops "
            << slam.counters().cross_robot_loops << "\n";
  for (const llc::CrossRobotLoop& loop : slam.crossLoops()) {
    if (!loop.record.applied) continue;
    const llc::Pose2 truth = llc::between(truthOf(slam, drive, loop.from), truthOf(slam, drive, loop.to));
    const llc::Pose2 e = llc::between(truth, loop.record.loop.pose);
    EXPECT_LT(std::hypot(e.x, e.y), 0.5) << "a wrong cross-robot loop";
  }
  std::vector<llc::Pose2> map, truth;
  for (std::size_t m = 0; m < slam.map().keyframes().size(); ++m) {
    map.push_back(slam.map().poses()[m]);
    const llc::RobotKeyframe& k = slam.mapKeyframe(m);
    // The saved map's keyframes are robot 0's pipeline's, restored: their scan index is the frame.
    truth.push_back(drive.frames[slam.robot(k.robot).keyframes()[k.keyframe].scan_index].truth);
  }
  EXPECT_LT(llc::alignedRmsError(map, truth), 0.5);
  // Saved again: who was who (yesterday's robot 5, today's robot 1 after it: 6).
  const llc::SlamSession again = slam.session();
  ASSERT_EQ(again.robots.size(), again.keyframes.size());
  for (std::size_t m = 0; m < again.robots.size(); ++m)
    EXPECT_EQ(again.robots[m], m < saved.keyframes.size() ? 5u : 6u) << m;
  // The saved map takes no scans; a session that cannot be restored is refused.
  EXPECT_THROW(slam.addScan(0, llc_test::frameScan(drive, drive.frames[0]), 0, nullptr), std::invalid_argument);
  const llc::SlamSession empty;
  EXPECT_THROW(llc::MultiRobotSlam(llc_test::defaultModel(), 2, {}, {}, &empty), std::invalid_argument);
  EXPECT_THROW(llc::MultiRobotSlam(llc_test::defaultModel(), 1, {}, {}, &saved), std::invalid_argument);
}

TEST(MultiRobotSlam, EveryScanOfAJoinedRobotIsPlacedInTheMapNearItsTruth) {
  const TwoRobots& run = twoRobots();
  std::vector<llc::Pose2> map, truth;
  mapAndTruth(run.slam, run.drive, &map, &truth);
  llc::Pose2 truth_from_map;
  llc::alignedRmsError(map, truth, &truth_from_map);
  for (std::size_t robot = 0; robot < 2; ++robot) {
    const std::vector<llc::ScanPose> scans = run.slam.scanPoses(robot);
    ASSERT_GT(scans.size(), run.slam.robot(robot).keyframes().size());
    double worst = 0.0;
    for (const llc::ScanPose& s : scans) {
      const llc::Pose2 p = llc::compose(truth_from_map, s.pose);
      const llc::Pose2& t = run.drive.frames[s.scan_index].truth;
      worst = std::max(worst, std::hypot(p.x - t.x, p.y - t.y));
    }
    EXPECT_LT(worst, 0.5) << "robot " << robot;
  }
}

TEST(MultiRobotSlam, AJoinedRobotFindsOneThatDroveThereBefore) {
  // Robot 1 drives the second half first, alone; then robot 0 drives the first half, whose
  // streets robot 1 has seen: robot 0's keyframes find robot 1's and join it.
  const TwoRobots& run = twoRobots();
  const llc::SimDrive& drive = run.drive;
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 2);
  const llc::Pose2 frame_of_robot_1{40.0, -700.0, -1.0};
  for (std::size_t f = run.split; f < drive.frames.size(); ++f) {
    const llc::Pose2 odometry = llc::compose(frame_of_robot_1, drive.frames[f].odometry);
    slam.addScan(1, llc_test::frameScan(drive, drive.frames[f]), f, &odometry);
  }
  ASSERT_FALSE(slam.joined(1)) << "joined a map that was not there";
  std::size_t joined_at = 0;
  for (std::size_t f = 0; f < run.split; ++f) {
    const llc::RobotStep step = slam.addScan(0, llc_test::frameScan(drive, drive.frames[f]), f, &drive.frames[f].odometry);
    if (!step.joined_robots.empty()) {
      EXPECT_EQ(step.joined_robots, std::vector<std::size_t>{1});
      EXPECT_FALSE(step.joined_now) << "robot 0 is in the map from the start";
      joined_at = f;
    }
  }
  ASSERT_TRUE(slam.joined(1)) << "robot 0 drove past robot 1's streets and never joined it";
  std::cout << "robot 1 joined by robot 0's frame " << joined_at << "\n";
  std::size_t applied = 0;
  for (const llc::CrossRobotLoop& loop : slam.crossLoops()) {
    if (!loop.record.applied) continue;
    ++applied;
    const llc::Pose2 e = llc::between(llc::between(truthOf(slam, drive, loop.from), truthOf(slam, drive, loop.to)),
                                      loop.record.loop.pose);
    EXPECT_LT(std::hypot(e.x, e.y), 0.5) << "a wrong cross-robot loop";
  }
  EXPECT_GE(applied, 3u);
  std::vector<llc::Pose2> map, truth;
  mapAndTruth(slam, drive, &map, &truth);
  EXPECT_EQ(map.size(), slam.robot(0).keyframes().size() + slam.robot(1).keyframes().size());
  EXPECT_LT(llc::alignedRmsError(map, truth), 0.5);
}

TEST(MultiRobotSlam, TwoRobotsThatMeetAwayFromTheMapJoinItTogether) {
  // Robots 1 and 2 share streets that robot 0 never drives; robot 1 also drives streets robot 0
  // comes to later, robot 2 does not (checked by the truth). Robots 1 and 2 link; when robot 0
  // finds robot 1, robot 2 can only follow through that link.
  const llc::SimDrive& drive = twoRobots().drive;
  // Robot 0 drives [0, end0); robot 2 the first 150 frames after end0 + 40 that stay 15 m from
  // all of robot 0's; robot 1 from 60 frames before end0 to 80 frames into robot 2's.
  auto nearest = [&](std::size_t a0, std::size_t a1, std::size_t b0, std::size_t b1) {
    double d = 1e9;
    for (std::size_t i = a0; i < a1; i += 2)
      for (std::size_t j = b0; j < b1; j += 2)
        d = std::min(d, std::hypot(drive.frames[i].truth.x - drive.frames[j].truth.x, drive.frames[i].truth.y - drive.frames[j].truth.y));
    return d;
  };
  const std::size_t end0 = 350;
  std::size_t begin2 = end0 + 40;
  while (begin2 + 150 <= drive.frames.size() && nearest(0, end0, begin2, begin2 + 150) <= 15.0) begin2 += 10;
  ASSERT_LE(begin2 + 150, drive.frames.size()) << "no stretch of the drive away from robot 0's";
  const std::size_t end2 = begin2 + 150, begin1 = end0 - 60, end1 = begin2 + 80;
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 3);
  for (std::size_t f = 0; f < 120; ++f) slam.addScan(0, llc_test::frameScan(drive, drive.frames[f]), f, &drive.frames[f].odometry);
  const llc::Pose2 frame_1{300.0, 20.0, 0.5}, frame_2{-80.0, 900.0, -2.0};
  for (std::size_t f = begin1; f < end1; ++f) {
    const llc::Pose2 odometry = llc::compose(frame_1, drive.frames[f].odometry);
    slam.addScan(1, llc_test::frameScan(drive, drive.frames[f]), f, &odometry);
  }
  for (std::size_t f = begin2; f < end2; ++f) {
    const llc::Pose2 odometry = llc::compose(frame_2, drive.frames[f].odometry);
    slam.addScan(2, llc_test::frameScan(drive, drive.frames[f]), f, &odometry);
  }
  ASSERT_FALSE(slam.joined(1));
  ASSERT_FALSE(slam.joined(2));
  EXPECT_GE(slam.counters().robot_links, 1u) << "robots 1 and 2 drove the same streets and never agreed";
  EXPECT_EQ(slam.map().keyframes().size(), slam.robot(0).keyframes().size()) << "a linked pair touched the map";
  std::size_t together = 0;
  for (std::size_t f = 120; f < end0; ++f) {  // robot 0 drives on, into robot 1's streets only
    const llc::RobotStep step = slam.addScan(0, llc_test::frameScan(drive, drive.frames[f]), f, &drive.frames[f].odometry);
    together += step.joined_robots.size() == 2;
  }
  ASSERT_TRUE(slam.joined(1) && slam.joined(2)) << "joined: " << slam.joined(1) << slam.joined(2);
  EXPECT_EQ(together, 1u) << "robot 2 did not follow robot 1 in";
  std::size_t links_applied = 0;
  for (const llc::CrossRobotLoop& loop : slam.crossLoops()) {
    if (!loop.record.applied) continue;
    links_applied += loop.joining && loop.from.robot != 0 && loop.to.robot != 0;
    const llc::Pose2 e = llc::between(llc::between(truthOf(slam, drive, loop.from), truthOf(slam, drive, loop.to)),
                                      loop.record.loop.pose);
    EXPECT_LT(std::hypot(e.x, e.y), 0.5) << "a wrong cross-robot loop, robot " << loop.from.robot << " -> " << loop.to.robot;
  }
  EXPECT_GE(links_applied, 3u) << "the link's loops did not reach the map";
  std::vector<llc::Pose2> map, truth;
  mapAndTruth(slam, drive, &map, &truth);
  EXPECT_EQ(map.size(), slam.robot(0).keyframes().size() + slam.robot(1).keyframes().size() + slam.robot(2).keyframes().size());
  EXPECT_LT(llc::alignedRmsError(map, truth), 0.5);
}

TEST(MultiRobotSlam, ARobotThatNeverSeesTheMapNeverJoinsIt) {
  // Robot 1 drives where robot 0 has not been (checked by the truth), so any join is a guess.
  const llc::SimDrive& drive = twoRobots().drive;
  const std::size_t end0 = 120, begin1 = 360, end1 = 480;
  double nearest = 1e9;
  for (std::size_t i = 0; i < end0; ++i)
    for (std::size_t j = begin1; j < end1 && j < drive.frames.size(); ++j)
      nearest = std::min(nearest, std::hypot(drive.frames[i].truth.x - drive.frames[j].truth.x,
                                             drive.frames[i].truth.y - drive.frames[j].truth.y));
  ASSERT_GT(nearest, 15.0) << "the two stretches meet: pick others";
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 2);
  for (std::size_t i = 0; i < end0; ++i) slam.addScan(0, llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
  std::size_t validated = 0;
  for (std::size_t j = begin1; j < end1 && j < drive.frames.size(); ++j)
    validated += slam.addScan(1, llc_test::frameScan(drive, drive.frames[j]), j, &drive.frames[j].odometry).cross_validated;
  EXPECT_FALSE(slam.joined(1)) << "joined by " << validated << " look-alike loops";
  EXPECT_EQ(slam.map().keyframes().size(), slam.robot(0).keyframes().size()) << "an unjoined robot's keyframes reached the map";
  EXPECT_EQ(slam.counters().robots_joined, 1u);
  EXPECT_THROW(slam.mapIndex(1, 0), std::out_of_range);
}

TEST(MultiRobotSlam, BadInputIsRefusedOrSkippedNotFatal) {
  EXPECT_THROW(llc::MultiRobotSlam(llc_test::defaultModel(), 0), std::invalid_argument);
  llc::MultiRobotOptions bad;
  bad.cross_candidates = 0;
  EXPECT_THROW(llc::MultiRobotSlam(llc_test::defaultModel(), 2, {}, bad), std::invalid_argument);
  bad = {};
  bad.join.min_keyframes = 0;
  EXPECT_THROW(llc::MultiRobotSlam(llc_test::defaultModel(), 2, {}, bad), std::invalid_argument);

  const llc::SimDrive& drive = twoRobots().drive;
  llc::MultiRobotSlam slam(llc_test::defaultModel(), 2);
  EXPECT_THROW(slam.addScan(2, llc_test::frameScan(drive, drive.frames[0]), 0, &drive.frames[0].odometry), std::out_of_range);
  for (std::size_t i = 0; i < 40; ++i) slam.addScan(0, llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
  const std::size_t map_keyframes = slam.map().keyframes().size();
  // Robot 1: a scan with no stamp, one with NaN odometry, an empty one, then time going back.
  llc::Scan nan_stamp = llc_test::frameScan(drive, drive.frames[50]);
  nan_stamp.stamp = std::nan("");
  EXPECT_FALSE(slam.addScan(1, nan_stamp, 50, &drive.frames[50].odometry).slam.skip_reason.empty());
  const llc::Pose2 nan_pose{std::nan(""), 0.0, 0.0};
  EXPECT_FALSE(slam.addScan(1, llc_test::frameScan(drive, drive.frames[51]), 51, &nan_pose).slam.skip_reason.empty());
  llc::Scan empty;
  empty.stamp = drive.frames[52].stamp;
  EXPECT_NO_THROW(slam.addScan(1, empty, 52, &drive.frames[52].odometry));  // no returns at all: a scan like any (REP-117)
  for (std::size_t i = 60; i < 70; ++i) slam.addScan(1, llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
  slam.addScan(1, llc_test::frameScan(drive, drive.frames[55]), 55, &drive.frames[55].odometry);  // older than its last
  EXPECT_EQ(slam.map().keyframes().size(), map_keyframes + (slam.joined(1) ? slam.robot(1).keyframes().size() : 0));
  // Robot 0 goes on as if nothing happened.
  for (std::size_t i = 40; i < 60; ++i) slam.addScan(0, llc_test::frameScan(drive, drive.frames[i]), i, &drive.frames[i].odometry);
  EXPECT_GT(slam.robot(0).keyframes().size(), map_keyframes - (slam.joined(1) ? slam.robot(1).keyframes().size() : 0));
}

}  // namespace
