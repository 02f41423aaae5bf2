// rostest: the scan merger keeps publishing through bad input. Phases of one second each feed
// it NaN/inf/negative ranges, an empty scan, scans that change size, malformed geometry, a
// scanner frame with no tf and a tilted mount, a back scanner that stops and starts again; the
// test counts what comes out of scan360 in each phase.
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <limits>

#include "laser_loop_closure/Scan360.h"

namespace {

sensor_msgs::LaserScan scan(const std::string& frame, int beams, double range) {
  sensor_msgs::LaserScan msg;
  msg.header.frame_id = frame;
  msg.header.stamp = ros::Time::now();
  msg.angle_min = float(-M_PI / 2);
  msg.angle_increment = float(M_PI / double(beams - 1));
  msg.angle_max = float(msg.angle_min + double(beams - 1) * msg.angle_increment);
  msg.range_min = 0.1f;
  msg.range_max = 30.0f;
  msg.ranges.assign(std::size_t(beams), float(range));
  return msg;
}

geometry_msgs::TransformStamped mount(const std::string& child, double x, double yaw, double roll) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = "base_link";
  t.child_frame_id = child;
  t.transform.translation.x = x;
  tf2::Quaternion q;
  q.setRPY(roll, 0.0, yaw);
  t.transform.rotation.x = q.x(), t.transform.rotation.y = q.y(), t.transform.rotation.z = q.z(), t.transform.rotation.w = q.w();
  return t;
}

struct Counts {
  std::atomic<int> total{0}, full{0}, partial{0}, nonfinite_bearings{0};
};

class MergerTest : public testing::Test {
 protected:
  void SetUp() override {
    front_ = nh_.advertise<sensor_msgs::LaserScan>("scan_front", 50);
    back_ = nh_.advertise<sensor_msgs::LaserScan>("scan_back", 50);
    out_ = nh_.subscribe<laser_loop_closure::Scan360>("scan360", 100, [this](const laser_loop_closure::Scan360::ConstPtr& m) {
      ++counts_.total;
      ++(m->full_circle ? counts_.full : counts_.partial);
      for (float b : m->bearings)
        if (!std::isfinite(b)) ++counts_.nonfinite_bearings;
    });
    tf_.sendTransform({mount("laser_front", 0.2, 0.0, 0.0), mount("laser_back", -0.2, M_PI, 0.0),
                       mount("laser_upside_down", 0.2, 0.0, M_PI), mount("laser_tilted", 0.2, 0.0, 0.5)});
    const ros::WallTime start = ros::WallTime::now();
    while ((front_.getNumSubscribers() == 0 || back_.getNumSubscribers() == 0 || out_.getNumPublishers() == 0) &&
           (ros::WallTime::now() - start).toSec() < 20.0)
      ros::WallDuration(0.05).sleep();
    ros::WallDuration(1.0).sleep();
  }

  /// Publishes for `seconds` at 20 Hz; returns how many scan360 came out meanwhile.
  int phase(const std::function<void(sensor_msgs::LaserScan*, sensor_msgs::LaserScan*, bool*)>& make, double seconds = 1.0) {
    const int before = counts_.total;
    for (int i = 0; i < int(seconds * 20); ++i) {
      sensor_msgs::LaserScan f = scan("laser_front", 181, 5.0), b = scan("laser_back", 181, 6.0);
      bool send_back = true;
      make(&f, &b, &send_back);
      front_.publish(f);
      if (send_back) back_.publish(b);
      ros::WallDuration(0.05).sleep();
    }
    ros::WallDuration(0.3).sleep();  // let the last ones through
    return counts_.total - before;
  }

  ros::NodeHandle nh_;
  ros::Publisher front_, back_;
  ros::Subscriber out_;
  tf2_ros::StaticTransformBroadcaster tf_;
  Counts counts_;
};

TEST_F(MergerTest, KeepsPublishingThroughBadInput) {
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();

  const int full_before = counts_.full;
  EXPECT_GE(phase([](auto*, auto*, bool*) {}), 15) << "good pairs";
  EXPECT_GE(counts_.full - full_before, 15) << "pairs give 360-degree scans";

  EXPECT_GE(phase([&](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan* b, bool*) {
              for (std::size_t i = 0; i < f->ranges.size(); i += 4) f->ranges[i] = nan;
              for (std::size_t i = 1; i < f->ranges.size(); i += 4) f->ranges[i] = inf;
              for (std::size_t i = 2; i < f->ranges.size(); i += 4) f->ranges[i] = -inf;
              for (std::size_t i = 3; i < b->ranges.size(); i += 4) b->ranges[i] = -1.0f;
            }),
            15)
      << "NaN, inf and negative ranges";

  EXPECT_GE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->ranges.clear(); }), 15)
      << "an empty front scan";

  int toggle = 0;
  EXPECT_GE(phase([&](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan* b, bool*) {
              *f = scan("laser_front", (toggle++ % 2) ? 361 : 91, 4.0);
              *b = scan("laser_back", 721, 4.0);
            }),
            15)
      << "scans that change size";

  EXPECT_GE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->header.frame_id = "laser_upside_down"; }), 15)
      << "an upside-down front scanner";

  EXPECT_GE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan* b, bool*) {
              f->header.frame_id = "/laser_front";
              b->header.frame_id = "//laser_back";
            }),
            15)
      << "frame ids spelt the tf1 way, with a leading slash";

  // Malformed geometry, a frame with no tf and a tilted mount: skipped, with a warning. At most
  // one scan comes out: the previous phase's last pair, which ApproximateTime only releases
  // when it sees the next messages.
  EXPECT_LE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->angle_increment = 0.0f; }), 1);
  EXPECT_LE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->header.frame_id = "laser_unknown"; }), 1);
  EXPECT_LE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->header.frame_id = "laser_tilted"; }), 1);
  // The frame with no tf again (spelt with a slash): after mount_wait_scans (30) of its scans
  // it is taken to sit at the fallback mount, and its scans come out again.
  EXPECT_GE(phase([](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool*) { f->header.frame_id = "/laser_unknown"; }), 5)
      << "a scanner frame tf never mounts, on the fallback mount";

  // The back scanner stops: after back_timeout the front goes alone (180-degree scans).
  const int partial_before = counts_.partial;
  EXPECT_GE(phase([](sensor_msgs::LaserScan*, sensor_msgs::LaserScan*, bool* send_back) { *send_back = false; }, 2.0), 25)
      << "front alone";
  EXPECT_GE(counts_.partial - partial_before, 25);

  // Still front alone: scans that are not newer than the last one published (half a second
  // old, all of one stamp) are skipped, so the merged stream never goes back in time ...
  const ros::Time stale = ros::Time::now() - ros::Duration(0.5);
  EXPECT_EQ(phase([&](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool* send_back) {
              *send_back = false;
              f->header.stamp = stale;
            }),
            0)
      << "scans older than the last published one";
  // ... but a jump back of seconds (a looped bag) is a restart: mapping goes on.
  int step = 0;
  const ros::Time looped = ros::Time::now() - ros::Duration(5.0);
  EXPECT_GE(phase([&](sensor_msgs::LaserScan* f, sensor_msgs::LaserScan*, bool* send_back) {
              *send_back = false;
              f->header.stamp = looped + ros::Duration(0.05 * step++);
            }),
            15)
      << "a restart 5 s back";

  // ... and starts again: merged 360-degree scans again.
  phase([](auto*, auto*, bool*) {}, 0.5);
  const int full_again = counts_.full;
  EXPECT_GE(phase([](auto*, auto*, bool*) {}), 15) << "the back scanner is back";
  EXPECT_GE(counts_.full - full_again, 15);
  EXPECT_EQ(counts_.nonfinite_bearings, 0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_merger_robustness");
  return RUN_ALL_TESTS();
}
