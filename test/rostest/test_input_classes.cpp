// rostest: every class of awkward input driven through all three nodelets (scan_merger ->
// loop_closure -> esdf_backend). The test is its own player: it reads the simulated drive
// (front + back scanner, wheel odometry on /tf), publishes /clock, the scans and /tf itself,
// and edits one stretch of the drive per input class: slashed frame ids, REP-117 values
// (NaN, +-inf, negative, beyond range_max), a scanner that changes its beam count, the back
// scanner stopping and coming back at half rate with a clock offset, scans out of order by a
// fraction of a second, a gap of seconds in the scans and in the odometry, wheel odometry that
// jumps 1e9 m, a scanner frame tf never mounts, and the clock jumping back to the drive's start
// (a looped bag). For each class it asserts that keyframes go on coming from that stretch
// (mapping on), the class's warning on /rosout and its counter in the diagnostics; at the end
// the path is finite and near the drive, and all three nodelets still tell their health.
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <vector>

#include "laser_loop_closure/Keyframe.h"
#include "health_watch.hpp"
#include "wall_bounded.hpp"

namespace {

struct Item {
  double t = 0.0;  ///< s since the drive's start
  std::string topic;
  sensor_msgs::LaserScan scan;
  tf2_msgs::TFMessage tf;
};

/// What one stretch of the drive does to the messages: edit them in place, or return false to
/// leave one out. `t` is the message's second of the drive.
using Edit = std::function<bool(Item* item)>;

struct Phase {
  std::string name;
  double from = 0.0, to = 0.0;  ///< s of the drive
  Edit edit;
  std::string warning;  ///< a substring of the WARN it must cause on /rosout ("" none asked)
};

struct Seen {
  std::mutex mutex;
  std::vector<double> keyframe_stamps;  ///< in arrival order
  std::vector<bool> keyframe_full_circle;
  std::vector<std::string> warnings;
  nav_msgs::Path::ConstPtr path;
};

class Player {
 public:
  Player(ros::NodeHandle& nh, double rate) : rate_(rate) {
    clock_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    front_ = nh.advertise<sensor_msgs::LaserScan>("scan_front", 100);
    back_ = nh.advertise<sensor_msgs::LaserScan>("scan_back", 100);
    tf_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
    tf_static_ = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  }
  bool connected() const { return front_.getNumSubscribers() > 0 && back_.getNumSubscribers() > 0 && tf_.getNumSubscribers() > 0; }
  void publishStatic(const tf2_msgs::TFMessage& mounts) { tf_static_.publish(mounts); }

  /// Publishes `items` with t in [from, to) at `rate_` times the drive's speed, the clock first.
  void play(const std::vector<Item>& items, ros::Time start, double from, double to, const Edit& edit) {
    double last_t = -1.0;
    for (Item item : items) {
      if (item.t < from || item.t >= to) continue;
      if (last_t >= 0.0 && item.t > last_t) ros::WallDuration((item.t - last_t) / rate_).sleep();
      last_t = item.t;
      rosgraph_msgs::Clock clock;
      clock.clock = start + ros::Duration(item.t);
      clock_.publish(clock);
      if (edit && !edit(&item)) continue;
      if (item.topic == "/scan_front") front_.publish(item.scan);
      else if (item.topic == "/scan_back") back_.publish(item.scan);
      else tf_.publish(item.tf);
    }
  }

 private:
  double rate_;
  ros::Publisher clock_, front_, back_, tf_, tf_static_;
};

bool isScan(const Item& item) { return item.topic != "/tf"; }

/// A property name scripts/test prints: lower case, digits and underscores.
std::string slug(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (std::isalnum(static_cast<unsigned char>(c))) out += char(std::tolower(static_cast<unsigned char>(c)));
    else if (!out.empty() && out.back() != '_') out += '_';
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out;
}

TEST(InputClasses, MappingGoesOnThroughEveryClass) {
  ros::NodeHandle nh, pnh("~");
  std::string bag_path;
  pnh.getParam("bag", bag_path);
  if (!std::ifstream(bag_path).good()) GTEST_SKIP() << "no bag at '" << bag_path << "' (scripts/test simulates it)";
  double rate = 3.0;
  pnh.getParam("rate", rate);

  // The drive's first 160 s: scans, odom -> base_link and the mountings.
  std::vector<Item> items;
  tf2_msgs::TFMessage mounts;
  ros::Time start;
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
    rosbag::View view(bag);
    start = view.getBeginTime();
    for (const rosbag::MessageInstance& m : view) {
      const double t = (m.getTime() - start).toSec();
      if (t >= 160.0) break;
      Item item;
      item.t = t, item.topic = m.getTopic();
      if (item.topic == "/tf_static") {
        mounts = *m.instantiate<tf2_msgs::TFMessage>();
      } else if (item.topic == "/scan_front" || item.topic == "/scan_back") {
        item.scan = *m.instantiate<sensor_msgs::LaserScan>();
        items.push_back(item);
      } else if (item.topic == "/tf") {
        item.tf = *m.instantiate<tf2_msgs::TFMessage>();
        items.push_back(item);
      }
    }
  }
  ASSERT_FALSE(mounts.transforms.empty()) << "the bag has no /tf_static";

  Seen seen;
  ros::Subscriber keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>(
      "/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.keyframe_stamps.push_back(m->header.stamp.toSec());
        seen.keyframe_full_circle.push_back(m->scan.full_circle);
      });
  ros::Subscriber log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::Log::ConstPtr& m) {
    if (m->level < rosgraph_msgs::Log::WARN) return;
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.warnings.push_back(m->msg);
  });
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>("/path", 5, [&](const nav_msgs::Path::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.path = m;
  });
  const llc_test::HealthWatch merger(nh, "scan merger"), front_end(nh, "loop closure"), back_end(nh, "esdf backend");
  ros::AsyncSpinner spinner(2);
  spinner.start();

  Player player(nh, rate);
  const ros::WallTime connect_deadline = ros::WallTime::now() + ros::WallDuration(30.0);
  while (!player.connected() && ros::WallTime::now() < connect_deadline) ros::WallDuration(0.05).sleep();
  ASSERT_TRUE(player.connected()) << "the nodelets did not subscribe within 30 s";
  player.publishStatic(mounts);
  ros::WallDuration(1.0).sleep();

  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  int counter = 0;
  const std::vector<Phase> phases = {
      {"as recorded", 0, 12, nullptr, ""},
      {"frame ids with a leading slash", 12, 24,
       [](Item* i) {
         if (isScan(*i)) i->scan.header.frame_id = "/" + i->scan.header.frame_id;
         return true;
       },
       ""},
      {"NaN, +-inf, negative and beyond range_max (REP-117)", 24, 36,
       [&](Item* i) {
         if (!isScan(*i)) return true;
         auto& r = i->scan.ranges;
         for (std::size_t k = 0; k + 4 < r.size(); k += 5) {
           r[k] = nan, r[k + 1] = inf, r[k + 2] = -inf, r[k + 3] = -1.0f, r[k + 4] = i->scan.range_max + 5.0f;
         }
         return true;
       },
       ""},
      {"a front scanner that changes its beam count and increment", 36, 48,
       [](Item* i) {
         if (i->topic != "/scan_front" || i->t >= 42.0) return true;
         std::vector<float> every_other;
         for (std::size_t k = 0; k < i->scan.ranges.size(); k += 2) every_other.push_back(i->scan.ranges[k]);
         i->scan.ranges = every_other;
         i->scan.angle_increment *= 2.0f;
         i->scan.angle_max = i->scan.angle_min + float(every_other.size() - 1) * i->scan.angle_increment;
         return true;
       },
       "changed its geometry"},
      {"the back scanner stops", 48, 60, [](Item* i) { return i->topic != "/scan_back"; }, "no back scan for"},
      {"the back scanner returns at half the rate, 20 ms late", 60, 72,
       [&](Item* i) {
         if (i->topic != "/scan_back") return true;
         i->scan.header.stamp += ros::Duration(0.02);
         return counter++ % 2 == 0;
       },
       "talks again"},
      {"scans out of order by a fraction of a second", 72, 84,
       [&](Item* i) {
         // Every fifth scan pair is stamped 0.25 s early: older than the one published before it.
         if (isScan(*i) && int(std::lround(i->t * 10.0)) % 5 == 0) i->scan.header.stamp -= ros::Duration(0.25);
         return true;
       },
       "not newer than the last one published"},
      {"no scans for 8 s", 84, 96, [](Item* i) { return !(isScan(*i) && i->t >= 86.0 && i->t < 94.0); }, ""},
      {"no wheel odometry for 8 s", 96, 108, [](Item* i) { return !(i->topic == "/tf" && i->t >= 98.0 && i->t < 106.0); }, ""},
      {"wheel odometry jumps 1e9 m once", 108, 120,
       [](Item* i) {
         if (i->topic == "/tf" && std::abs(i->t - 112.0) < 0.05)
           for (auto& t : i->tf.transforms) t.transform.translation.x += 1e9;
         return true;
       },
       "wheel odometry jumped"},
      {"a front scanner frame tf never mounts", 120, 132,
       [](Item* i) {
         if (i->topic == "/scan_front") i->scan.header.frame_id = "laser_unmounted";
         return true;
       },
       "has no mounting"},
  };

  for (const Phase& phase : phases) {
    counter = 0;
    player.play(items, start, phase.from, phase.to, phase.edit);
  }
  // A looped bag: the clock jumps back to the drive's start (tf listeners clear their buffers;
  // the bag's /tf_static comes again), and the drive plays on from there.
  player.publishStatic(mounts);
  player.play(items, start, 0.0, 24.0, nullptr);

  // Drained: nothing waits in the front end and both ends agree on the keyframes, twice in a row.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(180.0);
  int same = 0;
  double last_keyframes = -1.0;
  while (same < 3 && ros::WallTime::now() < deadline) {
    ros::WallDuration(1.0).sleep();
    const double keyframes = back_end.value("keyframes");
    const bool drained = front_end.value("scans waiting for the front end") == 0 &&
                         front_end.value("keyframes") == keyframes && keyframes > 0;
    same = drained && keyframes == last_keyframes ? same + 1 : 0;
    last_keyframes = keyframes;
  }
  EXPECT_GE(same, 3) << "the nodelets did not settle within 180 s of wall time after the drive";
  ros::WallDuration(1.5).sleep();
  spinner.stop();

  std::lock_guard<std::mutex> lock(seen.mutex);
  // Keyframes of each stretch, by stamp. Keyframes come in scan order, so the loop's start
  // where their stamps fall back by more than 5 s.
  const double t0 = start.toSec();
  std::size_t marker = seen.keyframe_stamps.size();
  double newest = -1.0;
  for (std::size_t k = 0; k < seen.keyframe_stamps.size() && marker == seen.keyframe_stamps.size(); ++k) {
    if (newest >= 0.0 && seen.keyframe_stamps[k] < newest - 5.0) marker = k;
    newest = std::max(newest, seen.keyframe_stamps[k]);
  }
  auto keyframes_in = [&](double from, double to, bool after_loop, bool* any_full = nullptr, bool* any_partial = nullptr) {
    int n = 0;
    for (std::size_t k = after_loop ? marker : 0; k < (after_loop ? seen.keyframe_stamps.size() : marker); ++k) {
      const double t = seen.keyframe_stamps[k] - t0;
      if (t < from || t >= to) continue;
      ++n;
      if (any_full && seen.keyframe_full_circle[k]) *any_full = true;
      if (any_partial && !seen.keyframe_full_circle[k]) *any_partial = true;
    }
    return n;
  };
  auto warned = [&](const std::string& text) {
    for (const std::string& w : seen.warnings)
      if (w.find(text) != std::string::npos) return true;
    return false;
  };
  for (const Phase& phase : phases) {
    const int n = keyframes_in(phase.from, phase.to, false);
    RecordProperty("keyframes_" + slug(phase.name), n);
    EXPECT_GE(n, 5) << phase.name << ": mapping did not go on";
    if (!phase.warning.empty()) {
      EXPECT_TRUE(warned(phase.warning)) << phase.name << ": no WARN with '" << phase.warning << "'";
    }
  }
  // The gaps: keyframes after them, close to where the scans and the odometry came back.
  EXPECT_GE(keyframes_in(94.0, 96.0, false), 1) << "no keyframe right after the gap in the scans";
  EXPECT_GE(keyframes_in(98.0, 108.0, false), 3) << "no keyframes in or after the gap in the odometry";
  // Front alone in the back scanner's silence, merged again once it is back.
  bool full = false, partial = false;
  keyframes_in(50.0, 60.0, false, &full, &partial);
  EXPECT_TRUE(partial && !full) << "keyframes while the back scanner is silent must be the front's alone";
  full = false;
  keyframes_in(62.0, 72.0, false, &full);
  EXPECT_TRUE(full) << "no 360-degree keyframe after the back scanner came back";
  // The loop: a new chain, with keyframes of its own.
  const int after_loop = keyframes_in(0.0, 24.0, true);
  RecordProperty("keyframes_after_the_clock_jumped_back", after_loop);
  EXPECT_GE(after_loop, 10) << "mapping stopped when the clock jumped back";
  EXPECT_TRUE(warned("time jumped back")) << "no WARN about the clock jumping back";

  // Counters a user reads in the diagnostics.
  EXPECT_GE(merger.value("scan geometry changes (beams, first angle or increment)"), 1.0);
  EXPECT_GE(merger.value("back scanner outages"), 1.0);
  EXPECT_GE(merger.value("skipped scans, not newer than the last"), 1.0);
  EXPECT_GE(merger.value("scanner frames on the fallback mount"), 1.0);
  EXPECT_GE(front_end.value("wheel odometry jumps left out"), 1.0);
  EXPECT_GE(front_end.value("stamps that jumped back (new odometry chains)"), 1.0);
  EXPECT_GE(front_end.value("tf stamps that jumped back (tf history cleared)"), 1.0);
  EXPECT_EQ(front_end.value("malformed scans"), 0.0);
  for (const char* key : {"scans received", "scans processed", "scans skipped by the front end", "keyframes", "loops found",
                          "scans without wheel odometry", "scans given up at a jump back (their odometry never came)",
                          "scans given up, no odometry while a newer scan had it", "tf stamps that jumped back (tf history cleared)",
                          "scans dropped to catch up (max_lag)", "scans dropped, queue full (queue_size)"})
    RecordProperty("loop_closure_" + slug(key), std::to_string(front_end.value(key)));
  for (const char* key : {"keyframes", "refused keyframes", "keyframes loosely linked (odometry unusable)", "loops applied"})
    RecordProperty("esdf_backend_" + slug(key), std::to_string(back_end.value(key)));

  // The wheels' 1e9 m never reached a pose: the path is finite and stays within the drive.
  ASSERT_NE(seen.path, nullptr) << "no /path";
  EXPECT_EQ(double(seen.path->poses.size()), back_end.value("keyframes"));
  double farthest = 0.0;
  for (const auto& p : seen.path->poses) {
    ASSERT_TRUE(std::isfinite(p.pose.position.x) && std::isfinite(p.pose.position.y));
    farthest = std::max(farthest, std::hypot(p.pose.position.x, p.pose.position.y));
  }
  RecordProperty("farthest_pose_from_the_map_origin_m", std::to_string(farthest));
  EXPECT_LT(farthest, 2000.0) << "a pose far outside a 160 s drive";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_input_classes"); }
