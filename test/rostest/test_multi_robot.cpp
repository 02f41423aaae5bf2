// rostest: several robots, one map, through multi_robot.launch. The simulated drive cut into
// robots (llc simulate --robots N: fleet.bag; the robots after the first with their odometry in
// random frames, no relative prior) goes through one front end per robot and the
// multi_robot_backend. With loss_robot, that robot reaches the back end only through this test,
// which loses loss_seconds of its messages (a network outage: each keyframe and loop stamped in
// that window is dropped the first time it comes). Then: every robot is in the map, joined
// within 5 m of its own travel after it first saw places another robot had seen, none of its
// keyframes missing; and every robot's path lies on the truth (a robot joined at a wrong place
// would lie metres off it), within max_rms_ratio of llc slam's map of the whole drive when given.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "health_watch.hpp"
#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/PackedKeyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/SaveMap.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "wall_bounded.hpp"

namespace {

long long milliseconds(double stamp) { return std::llround(stamp * 1000.0); }

/// llc slam's trajectory.csv (index,stamp,x,y,theta): each keyframe's stamp and pose.
std::vector<std::pair<double, llc::Pose2>> readTrajectory(const std::string& path) {
  std::vector<std::pair<double, llc::Pose2>> rows;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<double> cells;
    std::stringstream split(line);
    for (std::string cell; std::getline(split, cell, ',');) cells.push_back(std::stod(cell));
    if (cells.size() == 5) rows.push_back({cells[1], {cells[2], cells[3], cells[4]}});
  }
  return rows;
}

/// A keyframe of a robot: its stamp and true pose.
using Stamped = std::pair<double, llc::Pose2>;

/// The stamp at which a robot's own path (its keyframes' truth) reached `path` m; +inf never.
double stampAtPath(const std::vector<Stamped>& own, double path) {
  double travelled = 0.0;
  for (std::size_t k = 0; k < own.size(); ++k) {
    if (k > 0) travelled += std::hypot(own[k].second.x - own[k - 1].second.x, own[k].second.y - own[k - 1].second.y);
    if (travelled >= path) return own[k].first;
  }
  return std::numeric_limits<double>::infinity();
}

/// The true path of a robot's keyframes (in order) until the third of them lies within 1.5 m of
/// a place in the map: a keyframe another robot made earlier, that robot being in the map by
/// then (`joined_at`: the stamp it joined; the first robot's is -inf). The earliest a join can
/// be right (the join's min_keyframes); -1 when that never happens.
double pathToFirstMapOverlap(const std::vector<Stamped>& own, const std::vector<std::vector<Stamped>>& others,
                             const std::vector<double>& joined_at) {
  double path = 0.0;
  int near = 0;
  for (std::size_t k = 0; k < own.size(); ++k) {
    if (k > 0) path += std::hypot(own[k].second.x - own[k - 1].second.x, own[k].second.y - own[k - 1].second.y);
    bool found = false;
    for (std::size_t o = 0; o < others.size() && !found; ++o) {
      if (joined_at[o] > own[k].first) continue;
      for (const auto& [stamp, pose] : others[o])
        if (stamp < own[k].first && std::hypot(pose.x - own[k].second.x, pose.y - own[k].second.y) < 1.5) {
          found = true;
          break;
        }
    }
    if (found && ++near == 3) return path;
  }
  return -1.0;
}

TEST(MultiRobot, EveryRobotJoinsOnTheTruthAndANetworkLossLosesNothing) {
  ros::NodeHandle nh, pnh("~");
  std::string bag_path, robot_names = "r1 r2 r3", loss_robot, reference;
  pnh.getParam("bag", bag_path);
  pnh.getParam("robots", robot_names);
  pnh.getParam("loss_robot", loss_robot);  // "": no loss
  pnh.getParam("reference", reference);    // llc slam's trajectory.csv of the whole drive, or ""
  if (!std::ifstream(bag_path).good()) GTEST_SKIP() << "no bag at '" << bag_path << "' (scripts/test simulates it)";
  std::vector<std::string> kRobots;
  std::stringstream names(robot_names);
  for (std::string name; names >> name;) kRobots.push_back(name);
  ASSERT_FALSE(kRobots.empty());
  double loss_start = 12.0, loss_seconds = 5.0, max_rms = 0.2, max_rms_ratio = 1.2;  // s after the bag's start; m
  pnh.getParam("loss_start", loss_start);
  pnh.getParam("loss_seconds", loss_seconds);
  pnh.getParam("max_rms", max_rms);
  pnh.getParam("max_rms_ratio", max_rms_ratio);
  // With a saved map of the same drive (map_session): every place is in the map from the start,
  // so every robot, the first included, joins within max_join_path m of its own path.
  double max_join_path = -1.0;
  pnh.getParam("max_join_path", max_join_path);
  // Without a saved map the first robot's frame is the map's: two robots at least.
  if (max_join_path < 0.0) ASSERT_GE(kRobots.size(), 2u);
  int saved_map_robots = int(kRobots.size());  // robots in the saved map (map_session)
  pnh.getParam("saved_map_robots", saved_map_robots);
  // m of travel after its third keyframe near a place in the map by which each robot must have
  // joined; negative: measured only (robots driving at once meet in an order the machine's load
  // decides: in one run r3 met the map 50.6 m before it joined, in others never before).
  double max_join_after_overlap = 5.0;
  pnh.getParam("max_join_after_overlap", max_join_after_overlap);

  // The truth of every robot, by stamp; and the bag's time span.
  std::map<std::string, std::map<long long, llc::Pose2>> truth;
  double bag_start = 0.0, bag_end = 0.0;
  {
    rosbag::Bag bag(bag_path);
    rosbag::View view(bag);
    bag_start = view.getBeginTime().toSec();
    bag_end = view.getEndTime().toSec();
    for (const rosbag::MessageInstance& m : view) {
      for (const std::string& robot : kRobots)
        if (m.getTopic() == "/" + robot + "/ground_truth") {
          const nav_msgs::Odometry::ConstPtr odom = m.instantiate<nav_msgs::Odometry>();
          truth[robot][milliseconds(odom->header.stamp.toSec())] = llc_ros::toPose2(odom->pose.pose);
        }
    }
  }
  for (const std::string& robot : kRobots) ASSERT_GT(truth[robot].size(), 100u) << robot << " has no ground truth in the bag";

  std::mutex mutex;
  // loss_robot over a network that loses everything stamped in [loss_start, loss_start +
  // loss_seconds) the first time it is sent (the launch file remaps the back end's input to
  // <loss_robot>/packed_keyframes_over_network and .../loop_closures_over_network).
  const double lost_from = bag_start + loss_start, lost_until = lost_from + loss_seconds;
  std::set<std::uint32_t> dropped_keyframes;
  std::set<std::pair<std::uint32_t, std::uint32_t>> dropped_loops;
  std::size_t relayed_again = 0;
  std::map<std::string, std::set<std::uint32_t>> front_end_keyframes;
  std::map<std::string, nav_msgs::Path::ConstPtr> paths;
  ros::Publisher keyframe_out, loop_out;
  if (!loss_robot.empty()) {
    keyframe_out = nh.advertise<laser_loop_closure::PackedKeyframe>("/" + loss_robot + "/packed_keyframes_over_network", 1000);
    loop_out = nh.advertise<laser_loop_closure::LoopClosure>("/" + loss_robot + "/loop_closures_over_network", 1000);
  }
  auto in_loss = [&](const ros::Time& stamp) { return stamp.toSec() >= lost_from && stamp.toSec() < lost_until; };
  std::vector<ros::Subscriber> subs, relay_subs;
  if (!loss_robot.empty()) {
    relay_subs.push_back(nh.subscribe<laser_loop_closure::PackedKeyframe>(
        "/" + loss_robot + "/packed_keyframes", 5000, [&](const laser_loop_closure::PackedKeyframe::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex);
          if (in_loss(m->stamp) && dropped_keyframes.insert(m->index).second) return;
          relayed_again += dropped_keyframes.count(m->index);
          keyframe_out.publish(m);
        }));
    relay_subs.push_back(nh.subscribe<laser_loop_closure::LoopClosure>(
        "/" + loss_robot + "/loop_closures", 5000, [&](const laser_loop_closure::LoopClosure::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex);
          if (in_loss(m->header.stamp) && dropped_loops.insert({m->from_keyframe, m->to_keyframe}).second) return;
          loop_out.publish(m);
        }));
  }
  for (const std::string& robot : kRobots) {
    subs.push_back(nh.subscribe<laser_loop_closure::Keyframe>(  // a keyframe that did not pack goes as it is
        "/" + robot + "/keyframes", 5000, [&, robot](const laser_loop_closure::Keyframe::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex);
          front_end_keyframes[robot].insert(m->index);
        }));
    subs.push_back(nh.subscribe<laser_loop_closure::PackedKeyframe>(
        "/" + robot + "/packed_keyframes", 5000, [&, robot](const laser_loop_closure::PackedKeyframe::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex);
          front_end_keyframes[robot].insert(m->index);
        }));
    subs.push_back(nh.subscribe<nav_msgs::Path>("/" + robot + "/path", 5, [&, robot](const nav_msgs::Path::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex);
      paths[robot] = m;
    }));
  }
  const llc_test::HealthWatch back_end(nh, "multi-robot backend");
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // Every link of each robot's chain subscribed before the bag plays: the bag's topics (its
  // scan_merger), its merged scans (its loop_closure) and its keyframes (the back end). On a busy
  // machine a front end can come up seconds after its merger; the first robot, which drives
  // first, then lost its first keyframes to it (seen once in CI: r1 387 keyframes of 480).
  std::vector<std::string> bag_topics{"/tf", "/tf_static"};
  for (const std::string& robot : kRobots)
    for (const char* topic : {"/scan_front", "/scan_back", "/scan360", "/packed_keyframes"}) bag_topics.push_back("/" + robot + topic);
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected(
      bag_topics,
      [&] {
        return back_end.seen() && (loss_robot.empty() || (keyframe_out.getNumSubscribers() > 0 && loop_out.getNumSubscribers() > 0 &&
                                                         relay_subs[0].getNumPublishers() > 0 && relay_subs[1].getNumPublishers() > 0));
      },
      300.0, &why))
      << why;

  // Until the drive went through and the back end holds every keyframe each front end made,
  // unchanged for three checks in a row; bounded in wall time.
  double max_wall_seconds = 800.0;
  pnh.getParam("max_wall_seconds", max_wall_seconds);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(max_wall_seconds);
  int settled = 0;
  double last_total = -1.0;
  while (ros::WallTime::now() < deadline) {
    ros::WallDuration(2.0).sleep();
    bool all_in = ros::Time::now().toSec() >= bag_end - 0.5;
    double total = 0.0;
    {
      std::lock_guard<std::mutex> lock(mutex);
      for (const std::string& robot : kRobots) {
        const double held = back_end.value(robot + " keyframes");
        total += held;
        all_in = all_in && held == double(front_end_keyframes[robot].size()) && back_end.value(robot + " keyframes held") == 0;
      }
    }
    settled = all_in && total == last_total ? settled + 1 : 0;
    last_total = total;
    if (settled >= 3) break;
  }
  ros::WallDuration(2.5).sleep();  // the last paths (published with the map, every 2 s)
  spinner.stop();

  // The map and the session, saved: the session holds every robot's keyframes, each its robot's.
  const std::string stem = "/tmp/llc_multi_robot_test_" + std::to_string(::getpid());
  laser_loop_closure::SaveMap save_map;
  save_map.request.path = stem;
  ASSERT_TRUE(llc_test::callWithin("/multi_robot_backend/save_map", &save_map, 120.0, &why)) << why;
  EXPECT_TRUE(save_map.response.success) << save_map.response.message;
  EXPECT_TRUE(std::ifstream(stem + ".pgm").good());
  laser_loop_closure::SaveSession save_session;
  save_session.request.path = stem + ".llcsession";
  ASSERT_TRUE(llc_test::callWithin("/multi_robot_backend/save_session", &save_session, 120.0, &why)) << why;
  ASSERT_TRUE(save_session.response.success) << save_session.response.message;
  const llc::SlamSession session = llc::loadSession(stem + ".llcsession");
  std::map<std::uint32_t, std::size_t> per_robot;
  for (const std::uint32_t robot : session.robots) ++per_robot[robot];
  // Saved again at bounded size (prune, lifelong/*): what is kept loads and rebuilds a back end.
  laser_loop_closure::SaveSession pruned_save;
  pruned_save.request.path = stem + "_pruned.llcsession";
  pruned_save.request.prune = true;
  ASSERT_TRUE(llc_test::callWithin("/multi_robot_backend/save_session", &pruned_save, 120.0, &why)) << why;
  ASSERT_TRUE(pruned_save.response.success) << pruned_save.response.message;
  const llc::SlamSession pruned = llc::loadSession(stem + "_pruned.llcsession");
  EXPECT_EQ(pruned.keyframes.size(), std::size_t(pruned_save.response.keyframes));
  EXPECT_GT(pruned.keyframes.size(), 0u);
  // A saved map of the same drive: every place the live robots saw is in it twice or more.
  if (max_join_path >= 0.0) EXPECT_LT(pruned.keyframes.size(), session.keyframes.size() * 2 / 3);
  else EXPECT_LE(pruned.keyframes.size(), session.keyframes.size());
  llc::SlamBackEnd restored;
  EXPECT_EQ(restored.restore(pruned), "") << "the pruned session does not rebuild a back end";
  RecordProperty("pruned_session_keyframes", int(pruned.keyframes.size()));
  for (const char* suffix : {".pgm", ".yaml", ".llcsession", "_pruned.llcsession"}) std::remove((stem + suffix).c_str());

  std::lock_guard<std::mutex> lock(mutex);
  RecordProperty("robots_joined", int(back_end.value("robots joined")));
  RecordProperty("cross_robot_loops", int(back_end.value("cross-robot loops")));
  if (!loss_robot.empty()) {
    RecordProperty(loss_robot + "_keyframes_dropped_by_the_network", int(dropped_keyframes.size()));
    RecordProperty(loss_robot + "_loops_dropped_by_the_network", int(dropped_loops.size()));
  }
  for (const std::string& robot : kRobots) {
    RecordProperty(robot + "_keyframes", int(front_end_keyframes[robot].size()));
    // Per second of the bag (robots that drive at once: of their drive; the wall time of a slow run is longer).
    const double bytes = back_end.value(robot + " bytes exchanged");
    RecordProperty(robot + "_bytes_per_bag_second", std::to_string(bytes / (bag_end - bag_start)));
    RecordProperty(robot + "_bytes_per_keyframe", std::to_string(bytes / double(front_end_keyframes[robot].size())));
    // Packed keyframes (about 90 bytes and the scan's 0.7 kB at pack_range_step 2 cm), loops and
    // place checks: 0.83-0.88 kB a keyframe on the 2 km drive (a Keyframe with its scan: 7 kB).
    // Not the robot whose lost keyframes were sent again.
    if (robot != loss_robot) EXPECT_LT(bytes / double(front_end_keyframes[robot].size()), 1000.0) << robot;
  }
  EXPECT_EQ(back_end.value("robots joined"), double(kRobots.size())) << "not every robot joined the map";
  if (max_join_path < 0.0) {
    ASSERT_EQ(per_robot.size(), kRobots.size()) << "the saved session does not hold every robot";
    for (std::size_t r = 0; r < kRobots.size(); ++r)
      EXPECT_EQ(per_robot[std::uint32_t(r)], front_end_keyframes[kRobots[r]].size()) << kRobots[r] << "'s keyframes in the session";
  } else {  // the saved map's robots, then each live robot after them
    EXPECT_EQ(per_robot.size(), std::size_t(saved_map_robots) + kRobots.size()) << "the saved map's robots and the live ones";
    for (std::size_t r = 0; r < kRobots.size(); ++r) {
      EXPECT_EQ(per_robot[std::uint32_t(saved_map_robots + int(r))], front_end_keyframes[kRobots[r]].size())
          << kRobots[r] << "'s keyframes in the session, after the saved map's";
      const double joined_after = back_end.value(kRobots[r] + " joined after m");
      RecordProperty(kRobots[r] + "_joined_the_saved_map_after_m", std::to_string(joined_after));
      EXPECT_GE(joined_after, 0.0) << kRobots[r] << " never joined the saved map";
      EXPECT_LT(joined_after, max_join_path) << kRobots[r] << " joined the saved map late";
    }
  }

  // The outage: the robot lost keyframes on the way, asked for them again, and none is missing.
  if (!loss_robot.empty()) {
    EXPECT_GT(dropped_keyframes.size(), 3u) << "the simulated outage dropped no keyframe";
    EXPECT_GT(relayed_again, 0u) << "no dropped keyframe was sent again";
  }
  for (const std::string& robot : kRobots) {
    EXPECT_EQ(back_end.value(robot + " keyframes"), double(front_end_keyframes[robot].size()))
        << robot << ": the back end does not hold every keyframe its front end made";
    EXPECT_EQ(back_end.value(robot + " keyframes refused"), 0.0) << robot;
    EXPECT_EQ(back_end.value(robot + " keyframes lost"), 0.0) << robot;
  }

  // Every robot's keyframes in the map frame, against the truth by stamp: one alignment for all.
  std::vector<llc::Pose2> estimate, reference_truth;
  std::map<std::string, std::vector<Stamped>> truth_path;  // per robot, its keyframes' truth
  for (const std::string& robot : kRobots) {
    ASSERT_NE(paths[robot], nullptr) << "no /" << robot << "/path";
    EXPECT_EQ(paths[robot]->header.frame_id, "map") << robot << "'s path is not in the map";
    EXPECT_EQ(paths[robot]->poses.size(), front_end_keyframes[robot].size()) << robot;
    for (const geometry_msgs::PoseStamped& pose : paths[robot]->poses) {
      const auto found = truth[robot].find(milliseconds(pose.header.stamp.toSec()));
      ASSERT_NE(found, truth[robot].end()) << robot << ": a keyframe stamped " << pose.header.stamp << " has no truth";
      estimate.push_back(llc_ros::toPose2(pose.pose));
      reference_truth.push_back(found->second);
      truth_path[robot].push_back({pose.header.stamp.toSec(), found->second});
    }
  }
  const double rms = llc::alignedRmsError(estimate, reference_truth);
  RecordProperty("map_rms_error_m", std::to_string(rms));
  std::cout << "map of " << estimate.size() << " keyframes of " << kRobots.size() << " robots: RMS " << rms << " m\n";
  EXPECT_LT(rms, max_rms) << "the joined map is off the truth (a robot joined at a wrong place?)";
  if (!reference.empty()) {  // llc slam's map of the whole drive by one robot, against the same truth
    std::map<long long, llc::Pose2> all_truth;
    for (const std::string& robot : kRobots) all_truth.insert(truth[robot].begin(), truth[robot].end());
    std::vector<llc::Pose2> one, one_truth;
    for (const auto& [stamp, pose] : readTrajectory(reference)) {
      const auto found = all_truth.find(milliseconds(stamp));
      if (found == all_truth.end()) continue;
      one.push_back(pose);
      one_truth.push_back(found->second);
    }
    ASSERT_GT(one.size(), 100u) << reference << ": no keyframe of it has a truth in the bag";
    const double one_rms = llc::alignedRmsError(one, one_truth);
    RecordProperty("one_robot_rms_error_m", std::to_string(one_rms));
    EXPECT_LT(rms, max_rms_ratio * one_rms) << "the joined map is less accurate than one robot's map of the drive";
  }

  // Each robot after the first joined within 5 m of its own travel after its third keyframe
  // within 1.5 m of a place in the map (the earliest a join can be right; a robot that joins
  // earlier, from farther, is fine; one that meets a robot not yet in the map follows it in
  // when that one joins).
  if (max_join_path >= 0.0) return;  // checked above: the saved map covers the drive
  std::vector<double> joined_at(kRobots.size(), -std::numeric_limits<double>::infinity());
  for (std::size_t r = 1; r < kRobots.size(); ++r) {
    const double joined_after = back_end.value(kRobots[r] + " joined after m");
    joined_at[r] = joined_after < 0.0 ? std::numeric_limits<double>::infinity() : stampAtPath(truth_path[kRobots[r]], joined_after);
  }
  for (std::size_t r = 1; r < kRobots.size(); ++r) {
    std::vector<std::vector<Stamped>> others;
    std::vector<double> others_joined_at;
    for (std::size_t o = 0; o < kRobots.size(); ++o)
      if (o != r) others.push_back(truth_path[kRobots[o]]), others_joined_at.push_back(joined_at[o]);
    const double overlap = pathToFirstMapOverlap(truth_path[kRobots[r]], others, others_joined_at);
    const double joined_after = back_end.value(kRobots[r] + " joined after m");
    RecordProperty(kRobots[r] + "_first_map_overlap_m", std::to_string(overlap));
    RecordProperty(kRobots[r] + "_joined_after_m", std::to_string(joined_after));
    if (overlap >= 0.0 && max_join_after_overlap >= 0.0)
      EXPECT_LT(joined_after - overlap, max_join_after_overlap) << kRobots[r] << " joined long after it first saw the map";
  }
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_multi_robot"); }
