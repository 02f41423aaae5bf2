// rostest: scans that come out of the order their driver numbered them (header.seq), as the
// Intel bag's do, through the three nodelets without wheel odometry (seq_order.test). The test
// writes a bag of a drive through a room whose scans are stamped in the order they are played
// but numbered out of it in three places, plays it with `rosbag play` (which keeps header.seq,
// as a live driver's numbering reaches scan_merger), and reads loop_closure's diagnostics:
//  - scan 20 comes after 21: its place has passed, it is skipped, and from then on the scans
//    are held for the ones numbered before them;
//  - 41 before 40, 62 before 60 and 61: each held until those came (2 held);
//  - 79 never comes: 80, held behind it, is handed on once no scan came for half a second.
// So 80 scans played, 1 skipped as late, 79 processed, 3 held. Without the reordering, or with
// a seq lost between scan_merger and loop_closure, the counters read otherwise.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <string>
#include <vector>

#include "health_watch.hpp"
#include "wall_bounded.hpp"

namespace {

/// The order the scans are played in: 0..80 but for the three places out of order and 79.
std::vector<std::uint32_t> playOrder() {
  std::vector<std::uint32_t> order;
  for (std::uint32_t k = 0; k <= 80; ++k) order.push_back(k);
  auto move = [&](std::uint32_t seq, std::uint32_t after) {  // seq comes right after `after`
    order.erase(std::find(order.begin(), order.end(), seq));
    order.insert(std::find(order.begin(), order.end(), after) + 1, seq);
  };
  move(20, 21);
  move(40, 41);
  move(60, 62), move(61, 60);
  order.erase(std::find(order.begin(), order.end(), 79u));
  return order;
}

/// The front scanner's view (181 beams over 180 degrees) from (x, 0) heading +x in a room
/// [0, 12] x [-3, 3] m: every wall a straight line, so ICP has both directions.
sensor_msgs::LaserScan roomScan(double x) {
  sensor_msgs::LaserScan scan;
  scan.header.frame_id = "base_link";  // on the base: no mount needed from tf
  scan.angle_min = float(-M_PI / 2), scan.angle_increment = float(M_PI / 180.0), scan.angle_max = float(M_PI / 2);
  scan.range_min = 0.1f, scan.range_max = 30.0f;
  for (int i = 0; i <= 180; ++i) {
    const double a = -M_PI / 2 + i * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
    double r = 1e9;
    if (c > 1e-9) r = std::min(r, (12.0 - x) / c);
    if (s > 1e-9) r = std::min(r, 3.0 / s);
    if (s < -1e-9) r = std::min(r, -3.0 / s);
    scan.ranges.push_back(float(r));
  }
  return scan;
}

TEST(SeqOrder, ScansOutOfTheirDriversOrderArePutBackInItWithoutWheels) {
  ros::NodeHandle nh;
  llc_test::HealthWatch loop_closure(nh, "loop closure");
  const std::string bag_path = "/tmp/llc_seq_order_" + std::to_string(::getpid()) + ".bag";
  const std::vector<std::uint32_t> order = playOrder();
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    const double start = ros::WallTime::now().toSec();
    for (std::size_t k = 0; k < order.size(); ++k) {
      sensor_msgs::LaserScan scan = roomScan(1.0 + 0.05 * order[k]);
      scan.header.seq = order[k];
      scan.header.stamp = ros::Time(start + 0.05 * double(k));  // stamped as played (the Intel bag: sorted by stamp)
      bag.write("/scan_front", scan.header.stamp, scan);
    }
    bag.close();
  }
  // Every nodelet up before the first scan: loop_closure's diagnostics tell it.
  ASSERT_TRUE(llc_test::waitUntilReady(60.0, [&] { return loop_closure.seen() && llc_test::everyTopicSubscribed({"/scan_front"}); }))
      << "loop_closure told no health, or scan_merger did not subscribe /scan_front, within 60 s";
  ASSERT_EQ(std::system(("rosbag play --quiet " + bag_path).c_str()), 0) << "rosbag play failed";
  std::remove(bag_path.c_str());
  const bool processed = llc_test::waitUntilReady(60.0, [&] {
    return loop_closure.value("scans processed") >= double(order.size() - 1) &&
           loop_closure.value("scans skipped, late for their place in header.seq order") >= 1.0;
  });
  EXPECT_TRUE(processed) << "scans processed " << loop_closure.value("scans processed");
  EXPECT_EQ(loop_closure.value("scans received"), double(order.size()));
  EXPECT_EQ(loop_closure.value("scans skipped, late for their place in header.seq order"), 1.0);
  EXPECT_EQ(loop_closure.value("scans held for the ones before them in header.seq order"), 3.0);
  EXPECT_EQ(loop_closure.value("scans processed"), double(order.size() - 1));
  EXPECT_GE(loop_closure.value("keyframes"), 3.0) << "4 m driven: a keyframe a metre";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_seq_order");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
