// rostest: `rosbag play -l` through the three nodelets (bag_loop.test). Before TfListener every
// scan after the first jump back was skipped for good (the tf buffer refused the new pass as
// TF_OLD_DATA) and the map silently stayed at its first pass. Asserts, from the diagnostics,
// that three jumps back are seen by the front end and by its tf listener, and that keyframes
// keep coming after each of them; every wait is bounded in wall time.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <fstream>

#include "health_watch.hpp"
#include "wall_bounded.hpp"

namespace {

TEST(BagLoop, MappingGoesOnThroughEveryPass) {
  ros::NodeHandle nh, pnh("~");
  std::string bag;
  pnh.getParam("bag", bag);
  if (!std::ifstream(bag).good()) GTEST_SKIP() << "no bag at '" << bag << "' (scripts/test simulates it)";
  const llc_test::HealthWatch merger(nh, "scan merger"), front_end(nh, "loop closure"), back_end(nh, "esdf backend");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // The player starts paused and goes on once the nodelets take the bag's topics: the passes
  // are counted from the front end's diagnostics, which must be there from the first scan.
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected({"/scan_front", "/scan_back", "/tf", "/tf_static"},
                                          [&] { return merger.seen() && front_end.seen() && back_end.seen(); }, 200.0,
                                          &why))
      << why;

  // Keyframes seen when the front end had counted each jump back (index = jumps so far).
  std::vector<double> keyframes_at_jump;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(300.0);
  while (ros::WallTime::now() < deadline) {
    ros::WallDuration(0.5).sleep();
    const double jumps = front_end.value("stamps that jumped back (new odometry chains)");
    const double keyframes = front_end.value("keyframes");
    while (jumps >= 0 && double(keyframes_at_jump.size()) <= jumps) keyframes_at_jump.push_back(keyframes);
    // Done once the third pass after a jump has made keyframes of its own.
    if (keyframes_at_jump.size() >= 4 && keyframes > keyframes_at_jump[3] + 20) break;
  }
  spinner.stop();
  RecordProperty("jumps_back", int(front_end.value("stamps that jumped back (new odometry chains)")));
  RecordProperty("tf_clears", int(front_end.value("tf stamps that jumped back (tf history cleared)")));
  RecordProperty("keyframes", int(front_end.value("keyframes")));
  RecordProperty("scans_without_wheel_odometry", int(front_end.value("scans without wheel odometry")));
  ASSERT_GE(keyframes_at_jump.size(), 4u) << "fewer than three jumps back seen in 300 s of wall time";
  EXPECT_GE(front_end.value("tf stamps that jumped back (tf history cleared)"), 3.0);
  // Each pass (30 s of a drive at 6 m/s, a keyframe every 1.4 m) makes about 100 keyframes.
  for (std::size_t pass = 1; pass + 1 < keyframes_at_jump.size(); ++pass)
    EXPECT_GT(keyframes_at_jump[pass + 1], keyframes_at_jump[pass] + 20) << "pass " << pass << " after a jump made no map";
  EXPECT_GT(front_end.value("keyframes"), keyframes_at_jump[3] + 20) << "the last pass made no map";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_bag_loop"); }
