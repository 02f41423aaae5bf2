// rostest: laser_scan_matcher's demo bag through the three nodelets with only scan_front given
// (demo_bag.test). The bag has one /scan in frame "/laser" and no tf at all: the merger must
// take tf1's slash, put the scanner at the fallback mount, and loop_closure must map without
// wheels. Asserts: no scan skipped, keyframes made, and /map (sent whole to a new subscriber) with walls in it.
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include <fstream>

#include "health_watch.hpp"
#include "wall_bounded.hpp"

namespace {

TEST(DemoBag, MapsTheRoomOutOfTheBox) {
  ros::NodeHandle nh, pnh("~");
  std::string bag;
  pnh.getParam("bag", bag);
  if (!std::ifstream(bag).good()) GTEST_SKIP() << "no bag at '" << bag << "' (../shared/data is not next to the repository)";
  const llc_test::HealthWatch merger(nh, "scan merger"), front_end(nh, "loop closure"), back_end(nh, "esdf backend");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // The player starts paused: a fixed start delay on a busy machine can lose the first scans
  // to a merger not yet subscribed, and 300 of the 360 must get through.
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected({"/scan"}, [&] { return merger.seen() && front_end.seen() && back_end.seen(); },
                                          200.0, &why))
      << why;
  // The bag has 360 scans; done when the back end's keyframes stand still for 6 s after some came.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(200.0);
  double last = -1.0;
  int still = 0;
  while (ros::WallTime::now() < deadline && still < 6) {
    ros::WallDuration(1.0).sleep();
    const double keyframes = back_end.value("keyframes");
    still = keyframes > 0 && keyframes == last && front_end.value("scans received") >= 300 ? still + 1 : 0;
    last = keyframes;
  }
  const nav_msgs::OccupancyGrid::ConstPtr map = llc_test::waitForMessageWithin<nav_msgs::OccupancyGrid>("/map", 10.0);
  spinner.stop();
  RecordProperty("scans_received", int(front_end.value("scans received")));
  RecordProperty("keyframes", int(back_end.value("keyframes")));
  RecordProperty("merger_skipped_scans", int(merger.value("skipped scans")));
  ASSERT_GE(front_end.value("scans received"), 300.0) << "scans did not get through the merger";
  EXPECT_EQ(merger.value("skipped scans"), 0.0) << "scans skipped (their frame id, or no mount)";
  EXPECT_EQ(merger.value("scanner frames on the fallback mount"), 1.0);
  EXPECT_EQ(front_end.value("scans without wheel odometry"), 0.0) << "scans lost waiting for wheels that never come";
  EXPECT_GE(back_end.value("keyframes"), 10.0);
  ASSERT_NE(map, nullptr) << "no /map for a new subscriber";
  std::size_t occupied = 0;
  for (const auto cell : map->data) occupied += cell >= 65;
  RecordProperty("occupied_cells", int(occupied));
  EXPECT_GT(occupied, 200u) << "the map has no walls";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_demo_bag"); }
