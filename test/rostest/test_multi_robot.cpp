// rostest: several robots, one map, through multi_robot.launch. The simulated drive cut into
// three robots driving at once (llc simulate --robots 3: fleet.bag; robots r2 and r3 with
// their odometry in random frames, no relative prior) goes through one front end per robot and
// the multi_robot_backend. r2 reaches the back end only through this test, which loses 5 s of
// its messages (a network outage: each keyframe and loop stamped in that window is dropped the
// first time it comes). Then: every robot is in the map, r2's missing keyframes were asked for
// again and none is missing from the map, and every robot's path lies on the truth (a robot
// joined at a wrong place would lie metres off it).
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "health_watch.hpp"
#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "wall_bounded.hpp"

namespace {

const std::vector<std::string> kRobots{"r1", "r2", "r3"};

long long milliseconds(double stamp) { return std::llround(stamp * 1000.0); }

TEST(MultiRobot, EveryRobotJoinsOnTheTruthAndANetworkLossLosesNothing) {
  ros::NodeHandle nh, pnh("~");
  std::string bag_path;
  pnh.getParam("bag", bag_path);
  if (!std::ifstream(bag_path).good()) GTEST_SKIP() << "no bag at '" << bag_path << "' (scripts/test simulates it)";
  double loss_start = 12.0, loss_seconds = 5.0;  // s after the bag's start
  pnh.getParam("loss_start", loss_start);
  pnh.getParam("loss_seconds", loss_seconds);

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
  // r2 over a network that loses everything stamped in [loss_start, loss_start + loss_seconds)
  // the first time it is sent.
  const double lost_from = bag_start + loss_start, lost_until = lost_from + loss_seconds;
  std::set<std::uint32_t> dropped_keyframes;
  std::set<std::pair<std::uint32_t, std::uint32_t>> dropped_loops;
  std::size_t relayed_again = 0;
  std::map<std::string, std::set<std::uint32_t>> front_end_keyframes;
  std::map<std::string, nav_msgs::Path::ConstPtr> paths;
  ros::Publisher keyframe_out = nh.advertise<laser_loop_closure::Keyframe>("/r2/keyframes_over_network", 1000);
  ros::Publisher loop_out = nh.advertise<laser_loop_closure::LoopClosure>("/r2/loop_closures_over_network", 1000);
  auto in_loss = [&](const ros::Time& stamp) { return stamp.toSec() >= lost_from && stamp.toSec() < lost_until; };
  std::vector<ros::Subscriber> subs;
  subs.push_back(nh.subscribe<laser_loop_closure::Keyframe>(
      "/r2/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        if (in_loss(m->header.stamp) && dropped_keyframes.insert(m->index).second) return;
        relayed_again += dropped_keyframes.count(m->index);
        keyframe_out.publish(m);
      }));
  subs.push_back(nh.subscribe<laser_loop_closure::LoopClosure>(
      "/r2/loop_closures", 5000, [&](const laser_loop_closure::LoopClosure::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        if (in_loss(m->header.stamp) && dropped_loops.insert({m->from_keyframe, m->to_keyframe}).second) return;
        loop_out.publish(m);
      }));
  for (const std::string& robot : kRobots) {
    subs.push_back(nh.subscribe<laser_loop_closure::Keyframe>(
        "/" + robot + "/keyframes", 5000, [&, robot](const laser_loop_closure::Keyframe::ConstPtr& m) {
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

  std::vector<std::string> bag_topics{"/tf", "/tf_static"};
  for (const std::string& robot : kRobots)
    for (const char* topic : {"/scan_front", "/scan_back"}) bag_topics.push_back("/" + robot + topic);
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected(
      bag_topics,
      [&] {
        return back_end.seen() && keyframe_out.getNumSubscribers() > 0 && loop_out.getNumSubscribers() > 0 &&
               subs[0].getNumPublishers() > 0 && subs[1].getNumPublishers() > 0;
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

  std::lock_guard<std::mutex> lock(mutex);
  RecordProperty("robots_joined", int(back_end.value("robots joined")));
  RecordProperty("cross_robot_loops", int(back_end.value("cross-robot loops")));
  RecordProperty("r2_keyframes_dropped_by_the_network", int(dropped_keyframes.size()));
  RecordProperty("r2_loops_dropped_by_the_network", int(dropped_loops.size()));
  for (const std::string& robot : kRobots) {
    RecordProperty(robot + "_keyframes", int(front_end_keyframes[robot].size()));
    // Per second of the drive (each robot drives the whole bag): the wall time of a slow run is longer.
    const double bytes = back_end.value(robot + " bytes received");
    RecordProperty(robot + "_bytes_per_drive_second", std::to_string(bytes / (bag_end - bag_start)));
    RecordProperty(robot + "_bytes_per_keyframe", std::to_string(bytes / double(front_end_keyframes[robot].size())));
  }
  EXPECT_EQ(back_end.value("robots joined"), 3.0) << "not every robot joined the map";

  // The outage: r2 lost keyframes on the way, asked for them again, and none is missing.
  EXPECT_GT(dropped_keyframes.size(), 3u) << "the simulated outage dropped no keyframe";
  EXPECT_GT(relayed_again, 0u) << "no dropped keyframe was sent again";
  EXPECT_EQ(back_end.value("r2 keyframes lost"), 0.0);
  for (const std::string& robot : kRobots) {
    EXPECT_EQ(back_end.value(robot + " keyframes"), double(front_end_keyframes[robot].size()))
        << robot << ": the back end does not hold every keyframe its front end made";
    EXPECT_EQ(back_end.value(robot + " keyframes refused"), 0.0) << robot;
  }

  // Every robot's keyframes in the map frame, against the truth by stamp: one alignment for all.
  std::vector<llc::Pose2> estimate, reference;
  for (const std::string& robot : kRobots) {
    ASSERT_NE(paths[robot], nullptr) << "no /" << robot << "/path";
    EXPECT_EQ(paths[robot]->header.frame_id, "map") << robot << "'s path is not in the map";
    EXPECT_EQ(paths[robot]->poses.size(), front_end_keyframes[robot].size()) << robot;
    for (const geometry_msgs::PoseStamped& pose : paths[robot]->poses) {
      const auto found = truth[robot].find(milliseconds(pose.header.stamp.toSec()));
      ASSERT_NE(found, truth[robot].end()) << robot << ": a keyframe stamped " << pose.header.stamp << " has no truth";
      estimate.push_back(llc_ros::toPose2(pose.pose));
      reference.push_back(found->second);
    }
  }
  const double rms = llc::alignedRmsError(estimate, reference);
  RecordProperty("map_rms_error_m", std::to_string(rms));
  std::cout << "map of " << estimate.size() << " keyframes of 3 robots: RMS " << rms << " m\n";
  EXPECT_LT(rms, 0.2) << "the joined map is off the truth (a robot joined at a wrong place?)";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_multi_robot"); }
