#include "laser_loop_closure/ros/io/bag_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/exception.h>
#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "laser_loop_closure/ros/io/bag_structure.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/serialized_bounds.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {
namespace {

/// Poses at times, for interpolation at a scan's stamp.
struct PoseTrack {
  std::vector<std::pair<ros::Time, llc::Pose2>> samples;  ///< (stamp, pose), stamps increasing

  void add(const ros::Time& stamp, const llc::Pose2& pose) {
    if (samples.empty() || stamp > samples.back().first) samples.emplace_back(stamp, pose);
  }
  /// Whether a stamp lies within the samples' span (where tf answers without extrapolating).
  bool covers(const ros::Time& stamp) const {
    return !samples.empty() && stamp >= samples.front().first && stamp <= samples.back().first;
  }
  /// As tf2 interpolates (its TimeCache): the ratio from whole nanoseconds, the position
  /// (1 - r) a + r b; the heading on the shortest arc. Held at the ends.
  llc::Pose2 at(const ros::Time& stamp) const {
    auto after = std::lower_bound(samples.begin(), samples.end(), stamp,
                                  [](const std::pair<ros::Time, llc::Pose2>& s, const ros::Time& t) { return s.first < t; });
    if (after == samples.begin()) return samples.front().second;
    if (after == samples.end()) return samples.back().second;
    const auto& [t1, b] = *after;
    const auto& [t0, a] = *(after - 1);
    const double f = double((stamp - t0).toNSec()) / double((t1 - t0).toNSec());
    return {(1.0 - f) * a.x + f * b.x, (1.0 - f) * a.y + f * b.y,
            llc::normalizeAngle(a.theta + f * llc::normalizeAngle(b.theta - a.theta))};
  }
};

/// Messages read as their bytes allow: rosbag's instantiate() lets a corrupted length claim
/// gigabytes before it fails, so the bytes are walked first (serializedMessageFits).
class CheckedMessages {
 public:
  CheckedMessages(const std::string& path, BagReadReport* report) : report_(report) {
    std::ifstream file(path, std::ios::binary | std::ios::ate);
    file_bytes_ = file ? std::uint64_t(file.tellg()) : 0;
  }
  /// The message as T; null when it holds another type (as instantiate) or is damaged (counted).
  template <class T>
  boost::shared_ptr<T> read(const rosbag::MessageInstance& m) {
    if (!m.isType<T>()) return nullptr;
    const std::uint32_t size = m.size();
    std::vector<std::uint8_t> bytes;
    if (size <= file_bytes_) {
      bytes.resize(size);
      ros::serialization::OStream out(bytes.data(), size);
      m.write(out);
    }
    if (size > file_bytes_ || !serializedMessageFits(m.getDataType(), bytes.data(), size)) {
      if (report_->damaged_messages++ == 0)
        report_->first_damaged = "a " + m.getDataType() + " on " + m.getTopic() + " at " + std::to_string(m.getTime().toSec()) +
                                 " s whose " + std::to_string(size) + " bytes do not hold it";
      return nullptr;
    }
    auto msg = boost::make_shared<T>();
    ros::serialization::IStream in(bytes.data(), size);
    ros::serialization::deserialize(in, *msg);
    return msg;
  }

 private:
  BagReadReport* report_;
  std::uint64_t file_bytes_ = 0;
};

/// The static transforms of the bag (/tf_static), for MountCache.
void loadStaticTransforms(rosbag::Bag& bag, CheckedMessages& messages, tf2::BufferCore* buffer) {
  rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf_static"}));
  for (const rosbag::MessageInstance& m : view) {
    const tf2_msgs::TFMessage::ConstPtr tf = messages.read<tf2_msgs::TFMessage>(m);
    if (!tf) continue;
    for (geometry_msgs::TransformStamped t : tf->transforms) {
      // tf1's leading slashes, as tf2 names the frames (tf2 refuses them otherwise).
      t.header.frame_id = tfFrame(t.header.frame_id), t.child_frame_id = tfFrame(t.child_frame_id);
      buffer->setTransform(t, "bag", true);
    }
  }
}

/// The scans in their driver's numbering, as the loop_closure nodelet takes them without wheels.
void putInSeqOrder(const llc::SeqReorderOptions& options, const std::vector<std::uint32_t>& seqs,
                   llc::ScanSequence* sequence, BagReadReport* r) {
  llc::SeqReorder<llc::LoggedScan> reorder(options);
  std::vector<llc::LoggedScan> ordered;
  ordered.reserve(sequence->scans.size());
  for (std::size_t k = 0; k < seqs.size(); ++k) reorder.push(seqs[k], std::move(sequence->scans[k]), &ordered);
  reorder.flush(&ordered);
  sequence->scans = std::move(ordered);
  r->seq_reorder = reorder.counters();
  const std::size_t late = reorder.counters().late_skipped;
  if (late > 0) {
    r->skipped_scans += late;
    if (r->first_problem.empty())
      r->first_problem = std::to_string(late) + " front scans came after their place in header.seq order had passed";
  }
}

}  // namespace

llc::ScanSequence readBagSequence(const std::string& path, const BagReadOptions& options, BagReadReport* report) {
  BagReadReport local;
  BagReadReport& r = report ? *report : local;
  r = BagReadReport{};
  rosbag::Bag bag;
  // rosbag reserves what a damaged length claims before reading it: walk the records first.
  if (const std::string problem = bagStructureProblem(path); !problem.empty())
    throw BagError(path + ": not a readable bag (" + problem + ")");
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": not a readable bag (" + e.what() + ")");
  }
  if (!std::isfinite(options.odometry_time_offset))
    throw BagError(path + ": the odometry time offset must be a finite number of seconds");
  try {
    tf2::BufferCore static_transforms;
    CheckedMessages messages(path, &r);
    loadStaticTransforms(bag, messages, &static_transforms);
    const BagTopics& topics = options.topics;
    std::vector<sensor_msgs::LaserScan::ConstPtr> fronts, backs;
    PoseTrack odometry, truth;
    std::string base = options.base_frame;
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{topics.front, topics.back, topics.odom, topics.truth}));
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == topics.front || topic == topics.back) {
        if (!m.isType<sensor_msgs::LaserScan>())
          throw BagError(path + ": " + topic + " does not hold sensor_msgs/LaserScan but " + m.getDataType());
        const sensor_msgs::LaserScan::ConstPtr scan = messages.read<sensor_msgs::LaserScan>(m);
        if (scan) (topic == topics.front ? fronts : backs).push_back(scan);
      } else {
        if (!m.isType<nav_msgs::Odometry>())
          throw BagError(path + ": " + topic + " does not hold nav_msgs/Odometry but " + m.getDataType());
        const nav_msgs::Odometry::ConstPtr odom = messages.read<nav_msgs::Odometry>(m);
        if (!odom) continue;
        if (topic == topics.odom) {
          if (base.empty() && !odom->child_frame_id.empty()) base = odom->child_frame_id;
          odometry.add(odom->header.stamp, toPose2(odom->pose.pose));
          ++r.odom_messages;
        } else {
          truth.add(odom->header.stamp, toPose2(odom->pose.pose));
          ++r.truth_messages;
        }
      }
    }
    if (base.empty()) base = "base_link";
    // Every static transform is loaded: a frame not mounted now never will be (one lookup).
    MountCache mountings(static_transforms, base, FallbackMount{options.fallback_mount, 1});
    auto mountOf = [&](const sensor_msgs::LaserScan& scan) {
      ScannerMount mount;
      std::string error;
      bool fell_back = false;
      if (!mountings.lookup(scan.header.frame_id, &mount, &error, &fell_back)) throw BagError(path + ": " + error);
      if (fell_back) r.fallback_frames.push_back(tfFrame(scan.header.frame_id));
      return mount;
    };
    r.front_messages = fronts.size();
    r.back_messages = backs.size();
    if (fronts.empty()) throw BagError(path + ": no sensor_msgs/LaserScan on the front topic " + topics.front);
    std::sort(backs.begin(), backs.end(), [](const auto& a, const auto& b) { return a->header.stamp < b->header.stamp; });
    r.truth_from_odometry = truth.samples.empty();

    llc::ScanSequence sequence;
    sequence.has_odometry = !odometry.samples.empty();
    sequence.source = path;
    double last_stamp = -std::numeric_limits<double>::infinity();
    std::vector<std::uint32_t> seqs;  ///< of the scans in sequence.scans
    auto skip = [&](const std::string& why) {
      ++r.skipped_scans;
      if (r.first_problem.empty()) r.first_problem = why;
    };
    for (const auto& front : fronts) {
      const double stamp = front->header.stamp.toSec();
      if (!(stamp > last_stamp)) {
        skip("a front scan at " + std::to_string(stamp) + " s is not newer than the one before it");
        continue;
      }
      const ros::Time& scan_time = front->header.stamp;
      if (options.skip_scans_outside_odometry && !odometry.samples.empty() && !odometry.covers(scan_time)) {
        ++r.scans_outside_odometry;
        skip("front scan at " + std::to_string(stamp) + " s: " +
             (scan_time < odometry.samples.front().first ? "before the first" : "after the last") +
             " odometry message (the nodelets get no odometry for it either: tf does not extrapolate)");
        continue;
      }
      llc::LoggedScan logged;
      std::string error;
      const ScannerMount front_mount = mountOf(*front);
      logged.front_mount = front_mount.pose;
      if (!toBaseScan(*front, front_mount, &logged.scan, &error)) {
        skip("front scan at " + std::to_string(stamp) + " s: " + error);
        continue;
      }
      last_stamp = stamp;
      logged.stamp = stamp;
      logged.recorded_ranges_key = llc::recordedRangesKey(std::vector<double>(front->ranges.begin(), front->ranges.end()));
      // The back scan nearest in time, if near enough.
      auto after = std::lower_bound(backs.begin(), backs.end(), front->header.stamp,
                                    [](const auto& b, const ros::Time& t) { return b->header.stamp < t; });
      const sensor_msgs::LaserScan* best = nullptr;
      for (auto it : {after, after == backs.begin() ? backs.end() : after - 1}) {
        if (it == backs.end()) continue;
        const double gap = std::abs((*it)->header.stamp.toSec() - stamp);
        if (gap <= options.max_merge_gap && (!best || gap < std::abs(best->header.stamp.toSec() - stamp))) best = it->get();
      }
      llc::Scan back;
      if (best && toBaseScan(*best, mountOf(*best), &back, &error)) {
        logged.scan = llc::mergeScans(logged.scan, back);
        ++sequence.merged_count;
      }
      logged.scan = asTransmitted(logged.scan);  // the numbers the nodelets get in Scan360
      // Where the nodelets read the wheels: at stamp + offset (the probe's, when there is one),
      // or at the stamp itself where the odometry does not reach that far (the start of a
      // drive); a scan whose own stamp the odometry does not reach they never get odometry for
      // (tf does not extrapolate). Times in whole nanoseconds, as tf keeps them.
      double offset = options.odometry_time_offset;
      if (options.odometry_time_offset_probe && !odometry.samples.empty())
        offset = options.odometry_time_offset_probe->observe(stamp, logged.scan, [&](double shift, llc::Pose2* pose) {
          const ros::Time t = offsetStamp(scan_time, shift);
          if (!odometry.covers(t)) return false;
          *pose = canonicalWheelPose(odometry.at(t));
          return true;
        });
      const ros::Time shifted = offsetStamp(scan_time, offset);
      const ros::Time odometry_time = odometry.covers(shifted) || !odometry.covers(scan_time) ? shifted : scan_time;
      logged.odometry = odometry.samples.empty() ? llc::Pose2{} : canonicalWheelPose(odometry.at(odometry_time));
      logged.truth = truth.samples.empty() ? logged.odometry : truth.at(scan_time);
      sequence.scans.push_back(std::move(logged));
      seqs.push_back(front->header.seq);
    }
    if (options.without_wheels || odometry.samples.empty()) putInSeqOrder(options.seq_reorder, seqs, &sequence, &r);
    return sequence;
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": the bag is damaged or truncated (" + e.what() + ")");
  } catch (const ros::Exception& e) {  // the serializer's overruns: a record's bytes end early
    throw BagError(path + ": the bag is damaged or truncated (" + e.what() + ")");
  } catch (const BagError&) {
    throw;
  } catch (const std::runtime_error& e) {  // rostime's: stamps so far apart a duration cannot hold them
    throw BagError(path + ": the bag is damaged (" + e.what() + ")");
  }
}

namespace {

/// A connection header that marks a topic latched, as `rosbag record` stores /tf_static.
template <typename T>
boost::shared_ptr<ros::M_string> latchedConnection() {
  auto header = boost::make_shared<ros::M_string>();
  (*header)["type"] = ros::message_traits::datatype<T>();
  (*header)["md5sum"] = ros::message_traits::md5sum<T>();
  (*header)["message_definition"] = ros::message_traits::definition<T>();
  (*header)["callerid"] = "/llc_simulate";
  (*header)["latching"] = "1";
  return header;
}

sensor_msgs::LaserScan scanMessage(const llc::SimScannerOptions& scanner, const std::vector<double>& ranges,
                                   const std::string& frame, const ros::Time& stamp, double rate_hz) {
  sensor_msgs::LaserScan msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame;
  msg.angle_min = float(llc::simBeamAngle(scanner, 0));
  msg.angle_increment = float(llc::simBeamAngle(scanner, 1) - llc::simBeamAngle(scanner, 0));
  msg.angle_max = float(llc::simBeamAngle(scanner, scanner.beams - 1));
  msg.time_increment = 0.0f;  // the simulator takes every beam at the same instant
  msg.scan_time = float(1.0 / rate_hz);
  msg.range_min = 0.05f;
  msg.range_max = float(scanner.max_range);
  msg.ranges.assign(ranges.begin(), ranges.end());  // +inf stays +inf: no return (REP-117)
  return msg;
}

nav_msgs::Odometry odometryMessage(const llc::Pose2& pose, const llc::Pose2& previous, double dt, const std::string& frame,
                                   const ros::Time& stamp, const std::string& child_frame) {
  nav_msgs::Odometry msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame;
  msg.child_frame_id = child_frame;
  msg.pose.pose = toPoseMsg(pose);
  if (dt > 0.0) {  // velocities in base_link from the step since the previous frame
    const llc::Pose2 step = llc::between(previous, pose);
    msg.twist.twist.linear.x = step.x / dt;
    msg.twist.twist.linear.y = step.y / dt;
    msg.twist.twist.angular.z = step.theta / dt;
  }
  return msg;
}

}  // namespace

void writeSimBag(const llc::SimDrive& drive, const std::string& path) { writeSimFleetBag({SimBagRobot{&drive}}, path); }

void writeSimFleetBag(const std::vector<SimBagRobot>& robots, const std::string& path) {
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    double first_stamp = std::numeric_limits<double>::infinity();
    for (const SimBagRobot& robot : robots)
      if (!robot.drive->frames.empty()) first_stamp = std::min(first_stamp, robot.drive->frames.front().stamp + robot.time_shift);
    const ros::Time start(kSimBagEpoch + (std::isfinite(first_stamp) ? first_stamp : 0.0));
    // One latched /tf_static with every robot's mounts (a player latches only the last message).
    tf2_msgs::TFMessage mounts;
    for (const SimBagRobot& robot : robots) {
      const llc::SimDrive& drive = *robot.drive;
      auto name = [&](const std::string& frame) { return robot.ns.empty() ? frame : robot.ns + "/" + frame; };
      std::vector<std::pair<const llc::SimScannerOptions*, std::string>> scanners{{&drive.front, "laser_front"}};
      if (drive.options.back_scanner) scanners.emplace_back(&drive.back, "laser_back");
      for (const auto& [scanner, frame] : scanners) {
        geometry_msgs::TransformStamped t;
        t.header.stamp = start;
        t.header.frame_id = name("base_link");
        t.child_frame_id = name(frame);
        t.transform = toTransformMsg(scanner->mount);
        mounts.transforms.push_back(t);
      }
    }
    bag.write("/tf_static", start, mounts, latchedConnection<tf2_msgs::TFMessage>());
    for (const SimBagRobot& robot : robots) {
      const llc::SimDrive& drive = *robot.drive;
      auto name = [&](const std::string& frame) { return robot.ns.empty() ? frame : robot.ns + "/" + frame; };
      for (std::size_t k = 0; k < drive.frames.size(); ++k) {
        const llc::SimFrame& frame = drive.frames[k];
        const llc::SimFrame& previous = drive.frames[k > 0 ? k - 1 : 0];
        const ros::Time stamp(kSimBagEpoch + frame.stamp + robot.time_shift);
        const double dt = frame.stamp - previous.stamp;
        const llc::Pose2 odometry = llc::compose(robot.odometry_frame, frame.odometry);
        const nav_msgs::Odometry odom = odometryMessage(odometry, llc::compose(robot.odometry_frame, previous.odometry), dt,
                                                        name("odom"), stamp, name("base_link"));
        bag.write("/" + name("odom"), stamp, odom);
        tf2_msgs::TFMessage tf;
        geometry_msgs::TransformStamped t;
        t.header = odom.header;
        t.child_frame_id = odom.child_frame_id;
        t.transform = toTransformMsg(odometry);
        tf.transforms.push_back(t);
        bag.write("/tf", stamp, tf);
        bag.write("/" + name("ground_truth"), stamp,
                  odometryMessage(frame.truth, previous.truth, dt, "world", stamp, name("base_link")));
        bag.write("/" + name("scan_front"), stamp,
                  scanMessage(drive.front, frame.front, name("laser_front"), stamp, drive.options.rate_hz));
        if (drive.options.back_scanner)
          bag.write("/" + name("scan_back"), stamp,
                    scanMessage(drive.back, frame.back, name("laser_back"), stamp, drive.options.rate_hz));
      }
    }
    bag.close();
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": cannot write the bag (" + e.what() + ")");
  }
}

}  // namespace llc_ros
