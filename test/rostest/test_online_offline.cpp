// rostest: online = offline. The simulated drive played by `rosbag play` through the three
// nodelets must give what `llc slam --bag` gave on the same bag with the same parameters
// (scripts/test runs it first: build/test_data/sim/slam): the same keyframes (by stamp), the
// same applied loops (by the stamps of their keyframes) and final keyframe poses within 1 cm.
// The place gate runs in both: the nodelets ask the back end through ~place_check, which
// answers from the state llc slam's back end has at that moment. The launch file keeps the
// front end from skipping scans to catch up (max_lag 0, a long queue), so the outcome does not
// depend on how busy the machine is. Both read the wheels 0.05 s before each scan's stamp
// (odometry_time_offset; --odometry-time-offset), half the drive's scan period: the nodelet
// from tf, llc slam from the bag's /odom, each interpolating.
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>

#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <vector>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "health_watch.hpp"
#include "wall_bounded.hpp"

namespace {

struct OfflinePose {
  long scan = 0;
  double stamp = 0.0, x = 0.0, y = 0.0, theta = 0.0;
};

/// Rows of a CSV with a header line, split at commas.
std::vector<std::vector<std::string>> readCsv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream split(line);
    for (std::string cell; std::getline(split, cell, ',');) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

/// A stamp as an integer number of milliseconds: keys that compare exactly.
long long milliseconds(double stamp) { return std::llround(stamp * 1000.0); }

TEST(OnlineOffline, NodeletsGiveWhatLlcSlamGives) {
  ros::NodeHandle nh, pnh("~");
  std::string bag, offline;
  pnh.getParam("bag", bag);
  pnh.getParam("offline", offline);
  if (!std::ifstream(bag).good()) GTEST_SKIP() << "no bag at '" << bag << "' (scripts/test simulates it)";
  if (!std::ifstream(offline + "/trajectory.csv").good())
    GTEST_SKIP() << "no llc slam output at '" << offline << "' (scripts/test makes it)";

  // llc slam's keyframes (trajectory.csv: index = scan number, stamp, x, y, theta) and loops
  // (loops.csv: a, b = scan numbers, accepted).
  std::vector<OfflinePose> offline_poses;
  std::map<long, double> stamp_of_scan;
  for (const auto& row : readCsv(offline + "/trajectory.csv")) {
    ASSERT_EQ(row.size(), 5u);
    OfflinePose p{std::stol(row[0]), std::stod(row[1]), std::stod(row[2]), std::stod(row[3]), std::stod(row[4])};
    stamp_of_scan[p.scan] = p.stamp;
    offline_poses.push_back(p);
  }
  std::set<std::pair<long long, long long>> offline_loops;
  for (const auto& row : readCsv(offline + "/loops.csv")) {
    ASSERT_GE(row.size(), 3u);
    if (row[2] != "1") continue;
    offline_loops.insert({milliseconds(stamp_of_scan.at(std::stol(row[0]))), milliseconds(stamp_of_scan.at(std::stol(row[1])))});
  }
  ASSERT_GT(offline_poses.size(), 100u);
  ASSERT_GT(offline_loops.size(), 20u);

  std::mutex mutex;
  std::vector<double> keyframe_stamps;
  std::set<std::pair<long long, long long>> online_loops;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> applied;  // keyframe indices
  nav_msgs::Path::ConstPtr path;
  ros::Subscriber keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>("/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    keyframe_stamps.push_back(m->header.stamp.toSec());
  });
  ros::Subscriber record_sub = nh.subscribe<laser_loop_closure::LoopClosure>(
      "/esdf_backend/loop_records", 5000, [&](const laser_loop_closure::LoopClosure::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        if (m->accepted) applied.push_back({m->from_keyframe, m->to_keyframe});
      });
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>("/path", 5, [&](const nav_msgs::Path::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    path = m;
  });
  const llc_test::HealthWatch merger(nh, "scan merger"), front_end(nh, "loop closure"), back_end(nh, "esdf backend");
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // The player starts paused. It goes on only when the nodelets are up and subscribed to the
  // bag's topics and this node is subscribed to theirs: on a busy machine a fixed delay can
  // lose the first scan to the nodelets, or the first keyframe to this node.
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected(
      {"/scan_front", "/scan_back", "/tf", "/tf_static"},
      [&] {
        return merger.seen() && front_end.seen() && back_end.seen() && keyframe_sub.getNumPublishers() > 0 &&
               record_sub.getNumPublishers() > 0 && path_sub.getNumPublishers() > 0;
      },
      300.0, &why))
      << why;

  // Until the whole drive went through: the back end holds as many keyframes as llc slam made
  // and nothing waits, three checks in a row; bounded in wall time.
  double max_wall_seconds = 900.0;
  pnh.getParam("max_wall_seconds", max_wall_seconds);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(max_wall_seconds);
  int settled = 0;
  double last_keyframes = -1.0;
  while (ros::WallTime::now() < deadline) {
    ros::WallDuration(2.0).sleep();
    const double keyframes = back_end.value("keyframes");
    const bool quiet = front_end.value("scans waiting for the front end") == 0 &&
                       front_end.value("keyframes") == keyframes && back_end.value("keyframes held for their loops") == 0;
    // Done when it made as many keyframes as llc slam; or, when it made fewer, when nothing has
    // changed for 30 s (the comparison below then says what differs).
    const bool unchanged = quiet && keyframes > 0 && keyframes == last_keyframes;
    settled = unchanged ? settled + 1 : 0;
    if (unchanged && keyframes >= double(offline_poses.size()) && settled >= 3) break;
    if (settled >= 15) break;
    last_keyframes = keyframes;
  }
  ros::WallDuration(2.5).sleep();  // the last /path
  spinner.stop();

  std::lock_guard<std::mutex> lock(mutex);
  RecordProperty("offline_keyframes", int(offline_poses.size()));
  RecordProperty("online_keyframes", int(keyframe_stamps.size()));
  RecordProperty("offline_loops_applied", int(offline_loops.size()));
  RecordProperty("online_loops_applied", int(applied.size()));
  RecordProperty("place_checks_unanswered", int(front_end.value("place checks unanswered (aligned ungated)")));
  RecordProperty("keyframes_taken_without_their_loops", int(back_end.value("keyframes taken without all their loops (loop messages lost)")));
  RecordProperty("scans_dropped", int(front_end.value("scans dropped to catch up (max_lag)") + front_end.value("scans dropped, queue full (queue_size)")));

  // Keyframes: the same scans.
  ASSERT_EQ(keyframe_stamps.size(), offline_poses.size()) << "a different number of keyframes";
  std::size_t stamp_mismatches = 0;
  for (std::size_t k = 0; k < keyframe_stamps.size(); ++k)
    stamp_mismatches += milliseconds(keyframe_stamps[k]) != milliseconds(offline_poses[k].stamp);
  EXPECT_EQ(stamp_mismatches, 0u) << "keyframes made from other scans";

  // Loops: the same pairs applied.
  for (const auto& [from, to] : applied) {
    ASSERT_LT(std::max(from, to), keyframe_stamps.size());
    online_loops.insert({milliseconds(keyframe_stamps[from]), milliseconds(keyframe_stamps[to])});
  }
  std::size_t only_online = 0, only_offline = 0;
  for (const auto& loop : online_loops) only_online += offline_loops.count(loop) == 0;
  for (const auto& loop : offline_loops) only_offline += online_loops.count(loop) == 0;
  RecordProperty("loops_applied_only_online", int(only_online));
  RecordProperty("loops_applied_only_offline", int(only_offline));
  EXPECT_EQ(only_online, 0u);
  EXPECT_EQ(only_offline, 0u);

  // Final poses: within 1 cm (the map frame is the first keyframe's pose in both).
  ASSERT_NE(path, nullptr) << "no /path";
  ASSERT_EQ(path->poses.size(), offline_poses.size());
  double largest = 0.0;
  for (std::size_t k = 0; k < offline_poses.size(); ++k) {
    const auto& p = path->poses[k].pose.position;
    largest = std::max(largest, std::hypot(p.x - offline_poses[k].x, p.y - offline_poses[k].y));
  }
  RecordProperty("largest_pose_difference_m", std::to_string(largest));
  EXPECT_LT(largest, 0.01) << "final keyframe poses differ from llc slam's by more than 1 cm";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_online_offline"); }
