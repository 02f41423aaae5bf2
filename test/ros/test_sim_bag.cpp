// sim.bag read back with the C++ rosbag API (topics, types, frames, counts, REP-117 ranges,
// the latched /tf_static), then through the project's bag reader: 360-degree scans whose
// points lie on the simulated world's surfaces, the same scans as sim.log gives, and bad
// bags refused with a clear error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include "../core/test_util.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace {

struct SimFixture {
  llc::SimDriveOptions options;
  std::unique_ptr<llc::SimWorld> world;
  llc::SimDrive drive;
  explicit SimFixture(bool back = true) {
    options.seed = 3;
    options.length_m = 150.0;
    options.back_scanner = back;
    world = std::make_unique<llc::SimWorld>(llc::simWorldOptions(options));
    drive = llc::simulateDrive(*world, options);
  }
};

TEST(SimBag, HoldsTheTopicsFramesAndCountsOfTheDrive) {
  llc_test::TempDir dir;
  const SimFixture sim;
  llc_ros::writeSimBag(sim.drive, dir.file("sim.bag"));
  rosbag::Bag bag(dir.file("sim.bag"));
  rosbag::View view(bag);
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) types[c->topic] = c->datatype;
  const std::map<std::string, std::string> expected{{"/scan_front", "sensor_msgs/LaserScan"},
                                                    {"/scan_back", "sensor_msgs/LaserScan"},
                                                    {"/odom", "nav_msgs/Odometry"},
                                                    {"/ground_truth", "nav_msgs/Odometry"},
                                                    {"/tf", "tf2_msgs/TFMessage"},
                                                    {"/tf_static", "tf2_msgs/TFMessage"}};
  EXPECT_EQ(types, expected);
  std::map<std::string, std::size_t> counts;
  std::size_t no_return = 0, beams = 0;
  for (const rosbag::MessageInstance& m : view) {
    ++counts[m.getTopic()];
    if (m.getTopic() == "/scan_front" || m.getTopic() == "/scan_back") {
      const auto scan = m.instantiate<sensor_msgs::LaserScan>();
      ASSERT_TRUE(scan);
      EXPECT_EQ(scan->header.frame_id, m.getTopic() == "/scan_front" ? "laser_front" : "laser_back");
      ASSERT_EQ(scan->ranges.size(), 361u);
      EXPECT_NEAR(scan->angle_min, -M_PI / 2, 1e-6);
      EXPECT_NEAR(scan->angle_increment, M_PI / 360, 1e-7);
      EXPECT_FLOAT_EQ(scan->range_max, 80.0f);
      EXPECT_EQ(m.getTime(), scan->header.stamp);
      for (float r : scan->ranges) {
        ++beams;
        ASSERT_FALSE(std::isnan(r));
        if (std::isinf(r)) ++no_return;
        else ASSERT_TRUE(r >= scan->range_min && r <= scan->range_max) << r;
      }
    } else if (m.getTopic() == "/odom" || m.getTopic() == "/ground_truth") {
      const auto odom = m.instantiate<nav_msgs::Odometry>();
      ASSERT_TRUE(odom);
      EXPECT_EQ(odom->header.frame_id, m.getTopic() == "/odom" ? "odom" : "world");
      EXPECT_EQ(odom->child_frame_id, "base_link");
    } else if (m.getTopic() == "/tf_static") {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(tf);
      ASSERT_EQ(tf->transforms.size(), 2u);
      EXPECT_EQ(m.getConnectionHeader()->at("latching"), "1");
      for (const auto& t : tf->transforms) {
        EXPECT_EQ(t.header.frame_id, "base_link");
        if (t.child_frame_id == "laser_front") {
          EXPECT_DOUBLE_EQ(t.transform.translation.x, 1.5);
        } else {
          EXPECT_EQ(t.child_frame_id, "laser_back");
          EXPECT_DOUBLE_EQ(t.transform.translation.x, -1.0);
          EXPECT_NEAR(std::abs(t.transform.rotation.z), 1.0, 1e-12);  // turned by pi
        }
      }
    }
  }
  const std::size_t frames = sim.drive.frames.size();
  ASSERT_GT(frames, 150u);
  for (const char* topic : {"/scan_front", "/scan_back", "/odom", "/ground_truth", "/tf"}) EXPECT_EQ(counts[topic], frames) << topic;
  EXPECT_EQ(counts["/tf_static"], 1u);
  // Streets have open ends and parks: some beams return nothing, most do.
  EXPECT_GT(no_return, beams / 200);
  EXPECT_LT(no_return, beams / 2);
}

TEST(SimBag, TheReaderMerges360DegreeScansOnTheWorldsSurfacesAndAgreesWithSimLog) {
  llc_test::TempDir dir;
  const SimFixture sim;
  llc_ros::writeSimBag(sim.drive, dir.file("sim.bag"));
  llc::writeCarmenLog(sim.drive, dir.file("sim.log"));
  llc_ros::BagReadReport report;
  const llc::ScanSequence sequence = llc_ros::readBagSequence(dir.file("sim.bag"), {}, &report);
  const llc::ScanSequence from_log = llc::loadScanSequence(dir.file("sim.log"));
  const std::size_t frames = sim.drive.frames.size();
  ASSERT_EQ(sequence.scans.size(), frames);
  EXPECT_EQ(sequence.merged_count, frames);
  EXPECT_EQ(report.skipped_scans, 0u);
  EXPECT_FALSE(report.truth_from_odometry);
  std::size_t points = 0, on_surface = 0;
  for (std::size_t k = 0; k < frames; ++k) {
    const llc::LoggedScan& logged = sequence.scans[k];
    ASSERT_TRUE(logged.scan.full_circle);
    ASSERT_EQ(logged.scan.size(), 722u);
    EXPECT_NEAR(logged.truth.x, sim.drive.frames[k].truth.x, 1e-9);
    EXPECT_NEAR(logged.truth.theta, sim.drive.frames[k].truth.theta, 1e-9);
    EXPECT_NEAR(logged.odometry.y, sim.drive.frames[k].odometry.y, 1e-9);
    EXPECT_NEAR(logged.stamp - llc_ros::kSimBagEpoch, sim.drive.frames[k].stamp, 1e-6);
    // The same returns as the CARMEN log gives, to the log's millimetre and the bag's float
    // angles; front and back beams at almost the same bearing may swap places in the merge,
    // and no-return beams (below) sort elsewhere in the log.
    // (Beams without a return differ by design: +inf along the ray in the bag, a point at the
    // scanner's 80 m in the log.)
    const llc::Scan& other = from_log.scans[k].scan;
    ASSERT_EQ(other.size(), logged.scan.size());
    for (std::size_t i = 0; i < other.size(); i += 13) {
      if (std::isinf(logged.scan.ranges[i])) continue;
      bool found = false;
      for (std::size_t j = i >= 8 ? i - 8 : 0; j < std::min(other.size(), i + 9) && !found; ++j)
        found = std::abs(logged.scan.bearings[i] - other.bearings[j]) < 1e-4 &&
                std::abs(logged.scan.ranges[i] - other.ranges[j]) < 2e-3;
      EXPECT_TRUE(found) << "scan " << k << " beam " << i;
    }
    if (k % 20 != 0) continue;
    const double t = sim.drive.frames[k].stamp;
    const auto movers = sim.world->moverOutlines(t, logged.truth.x, logged.truth.y, 100.0);
    for (std::size_t i = 0; i < logged.scan.size(); i += 5) {
      const double r = logged.scan.ranges[i];
      if (!std::isfinite(r)) continue;
      const double b = logged.scan.bearings[i] + logged.truth.theta;
      ++points;
      on_surface += sim.world->distanceToSurface(logged.truth.x + r * std::cos(b), logged.truth.y + r * std::sin(b), t,
                                                 &movers) < 0.1;  // 5 sigma of the 2 cm noise
    }
  }
  ASSERT_GT(points, 500u);
  EXPECT_GT(double(on_surface) / double(points), 0.995) << on_surface << " of " << points;
}

TEST(SimBag, AFrontOnlyDriveGives180DegreeScans) {
  llc_test::TempDir dir;
  const SimFixture sim(false);
  llc_ros::writeSimBag(sim.drive, dir.file("front.bag"));
  const llc::ScanSequence sequence = llc_ros::readBagSequence(dir.file("front.bag"));
  ASSERT_EQ(sequence.scans.size(), sim.drive.frames.size());
  EXPECT_EQ(sequence.merged_count, 0u);
  EXPECT_FALSE(sequence.scans[0].scan.full_circle);
  EXPECT_EQ(sequence.scans[0].scan.size(), 361u);
}

/// A one-scan bag whose scanner is mounted by `rotation` (x, y, z, w) at (1, 0).
void writeMountBag(const std::string& path, double qx, double qy, double qz, double qw, bool mirrored_scan) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  const ros::Time t(100.0);
  tf2_msgs::TFMessage tf;
  geometry_msgs::TransformStamped mount;
  mount.header.frame_id = "base_link";
  mount.child_frame_id = "laser";
  mount.transform.translation.x = 1.0;
  mount.transform.rotation.x = qx, mount.transform.rotation.y = qy, mount.transform.rotation.z = qz,
  mount.transform.rotation.w = qw;
  tf.transforms.push_back(mount);
  bag.write("/tf_static", t, tf);
  sensor_msgs::LaserScan scan;
  scan.header.stamp = t;
  scan.header.frame_id = "laser";
  scan.angle_min = -0.5f, scan.angle_increment = 0.5f, scan.angle_max = 0.5f;
  scan.range_min = 0.1f, scan.range_max = 30.0f;
  scan.ranges = {2.0f, 3.0f, 4.0f};  // beams at -0.5, 0, 0.5 rad in the scanner frame
  if (mirrored_scan) std::reverse(scan.ranges.begin(), scan.ranges.end());
  bag.write("/scan_front", t, scan);
  bag.close();
}

TEST(SimBag, UpsideDownMountsAreMirroredAndTiltedOnesRefused) {
  llc_test::TempDir dir;
  writeMountBag(dir.file("level.bag"), 0, 0, 0, 1, false);
  // Rolled by pi: the sweep runs the other way seen from above, so the same points need the
  // ranges in reverse order.
  writeMountBag(dir.file("flipped.bag"), 1, 0, 0, 0, true);
  const llc::Scan level = llc_ros::readBagSequence(dir.file("level.bag")).scans.at(0).scan;
  const llc::Scan flipped = llc_ros::readBagSequence(dir.file("flipped.bag")).scans.at(0).scan;
  ASSERT_EQ(level.size(), 3u);
  ASSERT_EQ(flipped.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(level.ranges[i], flipped.ranges[i], 1e-6);
    EXPECT_NEAR(level.bearings[i], flipped.bearings[i], 1e-6);
  }
  // Point of the middle beam: 3 m ahead of a scanner 1 m ahead of the base.
  EXPECT_NEAR(level.ranges[1], 4.0, 1e-6);
  EXPECT_NEAR(level.bearings[1], 0.0, 1e-6);
  writeMountBag(dir.file("tilted.bag"), std::sin(0.15), 0, 0, std::cos(0.15), false);  // rolled by 0.3 rad
  try {
    llc_ros::readBagSequence(dir.file("tilted.bag"));
    FAIL() << "a tilted scanner was accepted";
  } catch (const llc_ros::BagError& e) {
    EXPECT_NE(std::string(e.what()).find("tilted"), std::string::npos) << e.what();
  }
}

TEST(SimBag, TheOdometryTimeOffsetReadsTheWheelsThatMuchBeforeTheScan) {
  llc_test::TempDir dir;
  const SimFixture sim;
  llc_ros::writeSimBag(sim.drive, dir.file("sim.bag"));
  const std::vector<llc::SimFrame>& frames = sim.drive.frames;
  ASSERT_GT(frames.size(), 10u);
  const double period = frames[1].stamp - frames[0].stamp;
  ASSERT_GT(period, 0.0);
  llc_ros::BagReadOptions options;
  options.odometry_time_offset = -period;  // each scan gets the odometry of the frame before it
  const llc::ScanSequence whole = llc_ros::readBagSequence(dir.file("sim.bag"), options);
  options.odometry_time_offset = -period / 2;  // half way between the two frames
  const llc::ScanSequence half = llc_ros::readBagSequence(dir.file("sim.bag"), options);
  ASSERT_EQ(whole.scans.size(), frames.size());
  ASSERT_EQ(half.scans.size(), frames.size());
  // The first scan has no odometry before it: it is held at the first message.
  EXPECT_NEAR(whole.scans[0].odometry.x, frames[0].odometry.x, 1e-9);
  std::size_t checked = 0;
  // From the third scan: the second's stamp minus a period, in whole nanoseconds, may fall a
  // nanosecond before the first odometry message, where tf, and so the reader, falls back.
  for (std::size_t k = 2; k < frames.size(); ++k) {
    if (std::abs((frames[k].stamp - frames[k - 1].stamp) - period) > 1e-6) continue;  // an uneven step
    ++checked;
    // Within 10 um: the bag's stamps are whole nanoseconds (at 1.6e9 s, a double's 0.2 us).
    const llc::Pose2 &before = frames[k - 1].odometry, &now = frames[k].odometry;
    EXPECT_NEAR(whole.scans[k].odometry.x, before.x, 1e-5) << k;
    EXPECT_NEAR(whole.scans[k].odometry.y, before.y, 1e-5) << k;
    EXPECT_NEAR(whole.scans[k].odometry.theta, before.theta, 1e-5) << k;
    EXPECT_NEAR(half.scans[k].odometry.x, (before.x + now.x) / 2, 1e-5) << k;
    EXPECT_NEAR(half.scans[k].odometry.y, (before.y + now.y) / 2, 1e-5) << k;
    EXPECT_GT(std::hypot(now.x - before.x, now.y - before.y), 1e-3) << k;  // the check can tell them apart
    // The truth is read at the scan's own stamp.
    EXPECT_NEAR(whole.scans[k].truth.x, frames[k].truth.x, 1e-9) << k;
  }
  EXPECT_GT(checked, frames.size() / 2);
  options.odometry_time_offset = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("sim.bag"), options), llc_ros::BagError);
}

TEST(SimBag, TheOdometryTimeOffsetProbeFindsOdometryStampedAPeriodEarlyAndReadsItThereFromThenOn) {
  llc_test::TempDir dir;
  llc::SimDriveOptions options;
  options.length_m = 600.0;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive truth = llc::simulateDrive(world, options);
  // Each odometry message stamped one period before the pose it holds (as a bag whose scans
  // are stamped a period late): read at a scan's stamp it gives the next frame's pose.
  llc::SimDrive early = truth;
  for (std::size_t k = 0; k + 1 < early.frames.size(); ++k) early.frames[k].odometry = truth.frames[k + 1].odometry;
  llc_ros::writeSimBag(early, dir.file("early.bag"));
  const double period = truth.frames[1].stamp - truth.frames[0].stamp;
  llc::OdometryTimeOffsetProbeOptions few;
  few.pairs = 20;  // the simulated drive turns seldom
  llc::OdometryTimeOffsetProbe probe(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0, few);
  llc_ros::BagReadOptions read;
  read.odometry_time_offset_probe = &probe;
  const llc::ScanSequence sequence = llc_ros::readBagSequence(dir.file("early.bag"), read);
  const llc::OdometryTimeOffsetProbeResult& r = probe.result();
  ASSERT_TRUE(r.decided && r.estimate.ok) << r.moving_pairs << " pairs; " << r.estimate.reason;
  EXPECT_NEAR(r.offset, -period, 1e-6) << r.estimate.reason;
  ASSERT_EQ(sequence.scans.size(), truth.frames.size());
  ASSERT_GT(r.decided_at_scan, 0u);
  ASSERT_LT(r.decided_at_scan + 10, sequence.scans.size());
  for (std::size_t k = 0; k < sequence.scans.size(); ++k) {
    // Up to the choice a frame ahead, from it on the scan's own (within the stamps' 10 um).
    const llc::Pose2& expected = k < r.decided_at_scan ? early.frames[k].odometry : truth.frames[k].odometry;
    ASSERT_NEAR(sequence.scans[k].odometry.x, expected.x, 1e-5) << k;
    ASSERT_NEAR(sequence.scans[k].odometry.y, expected.y, 1e-5) << k;
  }
  // In step, it keeps 0.
  llc::OdometryTimeOffsetProbe in_step(llc::ScanOdometry{}, llc::ScanAligner{}, 0.0, few);
  llc_ros::writeSimBag(truth, dir.file("sim.bag"));
  read.odometry_time_offset_probe = &in_step;
  llc_ros::readBagSequence(dir.file("sim.bag"), read);
  ASSERT_TRUE(in_step.result().decided);
  EXPECT_EQ(in_step.result().offset, 0.0) << in_step.result().estimate.reason;
}

TEST(SimBag, ScansOutsideTheOdometrysSpanAreSkippedForMappingAsTheNodeletsGiveThemUp) {
  // Odometry at 100.05, 100.2, 100.3 s (x = 0.5, 2, 3 m: 10 m/s, so x = 1 m at 100.1 s);
  // scans at 100.0 ... 100.4 s. tf answers within that span only, so the nodelets give up the
  // first scan and wait for ever with the last (FR079's bag starts with a scan 10 ms before
  // its first odometry).
  llc_test::TempDir dir;
  {
    rosbag::Bag bag(dir.file("span.bag"), rosbag::bagmode::Write);
    for (const auto& [t, x] : std::vector<std::pair<double, double>>{{100.05, 0.5}, {100.2, 2.0}, {100.3, 3.0}}) {
      nav_msgs::Odometry odom;
      odom.header.stamp = ros::Time(t);
      odom.header.frame_id = "odom";
      odom.child_frame_id = "base_link";
      odom.pose.pose.position.x = x;
      odom.pose.pose.orientation.w = 1.0;
      bag.write("/odom", ros::Time(t), odom);
    }
    for (int i = 0; i <= 4; ++i) {
      const double t = 100.0 + 0.1 * i;
      sensor_msgs::LaserScan scan;
      scan.header.stamp = ros::Time(t);
      scan.header.frame_id = "base_link";
      scan.angle_min = -0.5f, scan.angle_increment = 0.5f, scan.angle_max = 0.5f;
      scan.range_min = 0.1f, scan.range_max = 30.0f;
      scan.ranges = {2.0f, 3.0f, 4.0f};
      bag.write("/scan_front", ros::Time(t), scan);
    }
    bag.close();
  }
  llc_ros::BagReadReport report;
  const llc::ScanSequence held = llc_ros::readBagSequence(dir.file("span.bag"), {}, &report);
  ASSERT_EQ(held.scans.size(), 5u) << "off (pairs, features, laser-only mapping): every scan, the ends held";
  EXPECT_EQ(report.skipped_scans, 0u);
  EXPECT_NEAR(held.scans[0].odometry.x, 0.5, 1e-6);
  EXPECT_NEAR(held.scans[2].odometry.x, 2.0, 1e-6);
  EXPECT_NEAR(held.scans[4].odometry.x, 3.0, 1e-6);

  llc_ros::BagReadOptions mapping;
  mapping.skip_scans_outside_odometry = true;
  const llc::ScanSequence kept = llc_ros::readBagSequence(dir.file("span.bag"), mapping, &report);
  ASSERT_EQ(kept.scans.size(), 3u);
  EXPECT_NEAR(kept.scans.front().stamp, 100.1, 1e-6);
  EXPECT_NEAR(kept.scans.back().stamp, 100.3, 1e-6);
  EXPECT_EQ(report.skipped_scans, 2u);
  EXPECT_EQ(report.scans_outside_odometry, 2u);
  EXPECT_NE(report.first_problem.find("before the first odometry message"), std::string::npos) << report.first_problem;
  for (std::size_t k = 0; k < kept.scans.size(); ++k) EXPECT_NEAR(kept.scans[k].odometry.x, 1.0 + k, 1e-6) << k;

  // With an offset the wheels are read that much earlier, and where the odometry does not
  // reach that far (the first scan) at the scan's own stamp, as the nodelets fall back to.
  mapping.odometry_time_offset = -0.1;
  const llc::ScanSequence shifted = llc_ros::readBagSequence(dir.file("span.bag"), mapping);
  ASSERT_EQ(shifted.scans.size(), 3u);
  EXPECT_NEAR(shifted.scans[0].odometry.x, 1.0, 1e-6) << "at its own stamp, not held at the first message (0.5)";
  EXPECT_NEAR(shifted.scans[1].odometry.x, 1.0, 1e-6);
  EXPECT_NEAR(shifted.scans[2].odometry.x, 2.0, 1e-6);
}

TEST(SimBag, BadBagsAndTopicsGiveAClearError) {
  llc_test::TempDir dir;
  const SimFixture sim;
  llc_ros::writeSimBag(sim.drive, dir.file("sim.bag"));
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("missing.bag")), llc_ros::BagError);
  llc_test::writeText(dir.file("text.bag"), "not a bag\n");
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("text.bag")), llc_ros::BagError);
  {  // the first half of a good bag
    std::ifstream in(dir.file("sim.bag"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir.file("half.bag"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("half.bag")), llc_ros::BagError);
  llc_ros::BagReadOptions wrong;
  wrong.topics.front = "/odom";  // not LaserScan
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("sim.bag"), wrong), llc_ros::BagError);
  wrong = {};
  wrong.topics.front = "/nothing";
  EXPECT_THROW(llc_ros::readBagSequence(dir.file("sim.bag"), wrong), llc_ros::BagError);
}

TEST(SimBag, AScanWhoseLengthClaimsMoreThanItsBytesIsLeftOutAndCounted) {
  llc_test::TempDir dir;
  const SimFixture sim(false);
  llc_ros::writeSimBag(sim.drive, dir.file("sim.bag"));
  std::string bytes = llc_test::readText(dir.file("sim.bag"));
  // The sixth front scan's ranges length (after its frame_id and seven float32) set to 4.3e8:
  // 1.7 GB for roscpp's deserializer to allocate before it finds the bytes missing.
  const std::uint32_t beams = std::uint32_t(sim.drive.front.beams);
  std::size_t from = 0, found = 0, at = std::string::npos;
  while (found < 6) {
    const std::size_t name = bytes.find("laser_front", from);
    ASSERT_NE(name, std::string::npos);
    from = name + 1;
    std::uint32_t length = 0;
    std::memcpy(&length, bytes.data() + name + 11 + 28, sizeof length);
    if (length == beams && ++found == 6) at = name + 11 + 28;
  }
  const std::uint32_t claimed = 430000000u;
  bytes.replace(at, sizeof claimed, reinterpret_cast<const char*>(&claimed), sizeof claimed);
  std::ofstream(dir.file("damaged.bag"), std::ios::binary) << bytes;
  llc_ros::BagReadReport good, damaged;
  const llc::ScanSequence all = llc_ros::readBagSequence(dir.file("sim.bag"), {}, &good);
  const llc::ScanSequence read = llc_ros::readBagSequence(dir.file("damaged.bag"), {}, &damaged);
  EXPECT_EQ(good.damaged_messages, 0u);
  EXPECT_EQ(damaged.damaged_messages, 1u);
  EXPECT_NE(damaged.first_damaged.find("sensor_msgs/LaserScan on /scan_front"), std::string::npos) << damaged.first_damaged;
  ASSERT_EQ(read.scans.size() + 1, all.scans.size());
  EXPECT_EQ(read.scans[4].scan.ranges, all.scans[4].scan.ranges);
  EXPECT_EQ(read.scans[5].scan.ranges, all.scans[6].scan.ranges);  // the sixth left out, the rest as they were
}

TEST(SimBag, MalformedAndOutOfOrderScansAreSkippedAndAMissingMountFallsBack) {
  llc_test::TempDir dir;
  auto scanAt = [](double t, float increment) {
    sensor_msgs::LaserScan scan;
    scan.header.stamp = ros::Time(t);
    scan.header.frame_id = "laser";
    scan.angle_min = -0.5f, scan.angle_increment = increment, scan.angle_max = 0.5f;
    scan.range_min = 0.1f, scan.range_max = 30.0f;
    scan.ranges = {2.0f, std::numeric_limits<float>::quiet_NaN(), -1.0f};
    return scan;
  };
  {
    rosbag::Bag bag(dir.file("odd.bag"), rosbag::bagmode::Write);
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped mount;
    mount.header.frame_id = "base_link";
    mount.child_frame_id = "laser";
    mount.transform.rotation.w = 1.0;
    tf.transforms.push_back(mount);
    bag.write("/tf_static", ros::Time(100.0), tf);
    bag.write("/scan_front", ros::Time(100.0), scanAt(100.0, 0.5f));
    bag.write("/scan_front", ros::Time(100.1), scanAt(99.0, 0.5f));   // time went backwards
    bag.write("/scan_front", ros::Time(100.2), scanAt(100.2, 0.0f));  // zero angle increment
    bag.write("/scan_front", ros::Time(100.3), scanAt(100.3, 0.5f));
    bag.close();
  }
  llc_ros::BagReadReport report;
  const llc::ScanSequence sequence = llc_ros::readBagSequence(dir.file("odd.bag"), {}, &report);
  ASSERT_EQ(sequence.scans.size(), 2u);  // the two good ones, in order
  EXPECT_DOUBLE_EQ(sequence.scans[1].stamp, 100.3);
  EXPECT_EQ(report.skipped_scans, 2u);
  EXPECT_NE(report.first_problem.find("not newer"), std::string::npos) << report.first_problem;
  EXPECT_TRUE(report.truth_from_odometry);
  EXPECT_TRUE(std::isnan(sequence.scans[0].scan.ranges[1]));  // NaN passed on for the features to judge
  // No /tf_static at all and tf1's leading slash: the scanner sits at the fallback mount
  // (identity unless given), and the report names the frame so the tools can warn once.
  {
    rosbag::Bag bag(dir.file("nomount.bag"), rosbag::bagmode::Write);
    sensor_msgs::LaserScan scan = scanAt(100.0, 0.5f);
    scan.header.frame_id = "/laser";
    scan.ranges = {2.0f, 3.0f, 4.0f};
    bag.write("/scan_front", ros::Time(100.0), scan);
    scan.header.stamp = ros::Time(100.1);
    bag.write("/scan_front", ros::Time(100.1), scan);
    bag.close();
  }
  llc_ros::BagReadReport fallback_report;
  const llc::ScanSequence at_base = llc_ros::readBagSequence(dir.file("nomount.bag"), {}, &fallback_report);
  ASSERT_EQ(at_base.scans.size(), 2u);
  EXPECT_EQ(fallback_report.fallback_frames, std::vector<std::string>{"laser"}) << "named once";
  EXPECT_NEAR(at_base.scans[0].scan.ranges[1], 3.0, 1e-6);  // the middle beam, straight ahead
  EXPECT_NEAR(at_base.scans[0].scan.bearings[1], 0.0, 1e-6);
  llc_ros::BagReadOptions mounted;
  mounted.fallback_mount = {1.0, 0.0, 0.0};  // 1 m ahead of the base: the middle beam reaches 4 m
  const llc::ScanSequence ahead = llc_ros::readBagSequence(dir.file("nomount.bag"), mounted);
  EXPECT_NEAR(ahead.scans[0].scan.ranges[1], 4.0, 1e-6);
}

TEST(SimBag, WithoutWheelsTheScansArePutInHeaderSeqOrderAsTheNodeletTakesThem) {
  // As the Intel bag: stamps increasing in bag order, header.seq not (the log's scans, stamped
  // when written, sorted by stamp). The middle beam's range tells each scan's number.
  llc_test::TempDir dir;
  const std::vector<std::uint32_t> seqs{10, 11, 12, 14, 13, 15, 16, 18, 17, 19};
  {
    rosbag::Bag bag(dir.file("order.bag"), rosbag::bagmode::Write);
    for (std::size_t k = 0; k < seqs.size(); ++k) {
      const double t = 100.0 + 0.1 * double(k);
      nav_msgs::Odometry odom;
      odom.header.stamp = ros::Time(t);
      odom.header.frame_id = "odom";
      odom.child_frame_id = "base_link";
      odom.pose.pose.orientation.w = 1.0;
      bag.write("/odom", ros::Time(t), odom);
      sensor_msgs::LaserScan scan;
      scan.header.seq = seqs[k];
      scan.header.stamp = ros::Time(t);
      scan.header.frame_id = "base_link";
      scan.angle_min = -0.5f, scan.angle_increment = 0.5f, scan.angle_max = 0.5f;
      scan.range_min = 0.1f, scan.range_max = 30.0f;
      scan.ranges = {2.0f, float(seqs[k]) / 4.0f, 4.0f};
      bag.write("/scan_front", ros::Time(t), scan);
    }
    bag.close();
  }
  auto numbers = [](const llc::ScanSequence& sequence) {
    std::vector<std::uint32_t> found;
    for (const llc::LoggedScan& s : sequence.scans) found.push_back(std::uint32_t(std::lround(s.scan.ranges[1] * 4.0)));
    return found;
  };
  llc_ros::BagReadOptions options;
  options.seq_reorder.scans = 20;
  llc_ros::BagReadReport report;
  EXPECT_EQ(numbers(llc_ros::readBagSequence(dir.file("order.bag"), options, &report)), seqs) << "with wheels: as stamped";
  EXPECT_FALSE(report.seq_reorder.out_of_order_seen);

  // Without: 13 comes after 14 was handed on (skipped: the first scan out of order shows the
  // stream is); from then on 18 waits for 17.
  options.without_wheels = true;
  const llc::ScanSequence ordered = llc_ros::readBagSequence(dir.file("order.bag"), options, &report);
  EXPECT_EQ(numbers(ordered), (std::vector<std::uint32_t>{10, 11, 12, 14, 15, 16, 17, 18, 19}));
  EXPECT_EQ(report.seq_reorder.late_skipped, 1u);
  EXPECT_EQ(report.seq_reorder.reordered, 1u);
  EXPECT_EQ(report.skipped_scans, 1u);
  EXPECT_NE(report.first_problem.find("header.seq"), std::string::npos) << report.first_problem;
  EXPECT_NEAR(ordered.scans[6].stamp, 100.8, 1e-6) << "17 keeps its own stamp";
  options.seq_reorder.scans = 0;  // off
  EXPECT_EQ(numbers(llc_ros::readBagSequence(dir.file("order.bag"), options)), seqs);
}

}  // namespace
