// rostest: the simulated drive played through bag.launch's nodelets. Asserts what a user sees:
// map -> odom on /tf dated ahead of the clock and never paused for long, /map for a late subscriber and by its parts, a Path that grows to one pose
// per keyframe, at least 80% of the drive's true revisits closed and no wrong loop applied
// (checked against /ground_truth with the same code as `llc slam --evaluate`); then
// ~train_classifier on the session's keyframes answers, saves a model, and swaps it in only
// when it is at least as good as the running one; ~save_session writes the run and
// ~load_session restores it and hands its keyframes to the front end. With laser_only
// (bag_run_laser_only.test: no wheel odometry), also odom -> base_link from scan matching and
// map -> base_link at the end of the drive near the truth; services: false skips the services.
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/LoopClosure.h"
#include "laser_loop_closure/LoadSession.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/TrainClassifier.h"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/slam/slam_evaluation.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "child_process.hpp"
#include "health_watch.hpp"
#include "map_follower.hpp"
#include "wall_bounded.hpp"

namespace {

struct Observed {
  std::mutex mutex;
  std::map<double, llc::Pose2> truth;  // by stamp
  std::vector<double> keyframe_stamps;
  std::vector<bool> keyframe_full_circle;
  std::vector<llc::LoopRecord> records;
  std::vector<std::size_t> path_sizes;
  std::size_t map_to_odom = 0, map_to_odom_future = 0;
  // Wall time between consecutive map -> odom broadcasts while keyframes still come: a gap is
  // a stretch in which tf users (rviz, navigation) could not look the robot up in the map.
  ros::WallTime last_map_to_odom;
  double map_to_odom_max_gap = 0.0;
  std::size_t map_to_odom_long_gaps = 0;  ///< over 0.1 s (recorded)
  // The same in the broadcasts' own stamps (the back end's ROS clock): a player starved of CPU
  // stops the clock and so the broadcasts with it, which is no fault of the back end; only a
  // broadcast held back while the clock ran leaves a gap in its stamps.
  ros::Time last_map_to_odom_stamp;
  double map_to_odom_max_stamp_gap = 0.0;
  std::size_t map_to_odom_long_stamp_gaps = 0;  ///< over 0.4 s of ROS time (8 periods; recorded)
  // The newest map -> odom and odom -> base_link (the latter only comes from the nodelets
  // when the recorded odometry is kept out of tf: laser_only).
  geometry_msgs::TransformStamped newest_map_to_odom, newest_odom_to_base;
  std::size_t odom_to_base = 0;
  ros::WallTime last_message = ros::WallTime::now();
};

/// A planar transform (rotation about z only) as a pose.
llc::Pose2 planar(const geometry_msgs::Transform& t) {
  return {t.translation.x, t.translation.y, 2.0 * std::atan2(t.rotation.z, t.rotation.w)};
}

llc::Pose2 truthAt(const std::map<double, llc::Pose2>& truth, double stamp) {
  auto after = truth.lower_bound(stamp);
  if (after == truth.end()) return std::prev(after)->second;
  if (after == truth.begin() || std::abs(after->first - stamp) < std::abs(std::prev(after)->first - stamp))
    return after->second;
  return std::prev(after)->second;
}

TEST(BagRun, MapsTheSimulatedDrive) {
  ros::NodeHandle nh, pnh("~");
  std::string bag;
  pnh.getParam("bag", bag);
  if (!std::ifstream(bag).good()) GTEST_SKIP() << "no bag at '" << bag << "' (scripts/test simulates it)";
  double quiet_seconds = 20.0, max_wall_seconds = 900.0;
  pnh.getParam("quiet_seconds", quiet_seconds);
  pnh.getParam("max_wall_seconds", max_wall_seconds);
  // laser_only: no wheel odometry; the nodelets also broadcast odom -> base_link from scan
  // matching. services: call the four services after the drive.
  bool laser_only = false, services = true;
  pnh.getParam("laser_only", laser_only);
  pnh.getParam("services", services);
  double train_wall_seconds = 60.0;  // ~train_classifier trains for real on every pair of the session
  pnh.getParam("train_wall_seconds", train_wall_seconds);

  Observed seen;
  auto touch = [&] { seen.last_message = ros::WallTime::now(); };
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("/ground_truth", 5000, [&](const nav_msgs::Odometry::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.truth[m->header.stamp.toSec()] = llc_ros::toPose2(m->pose.pose);
  });
  ros::Subscriber keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>("/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.keyframe_stamps.push_back(m->header.stamp.toSec());
    seen.keyframe_full_circle.push_back(m->scan.full_circle);
    touch();
  });
  ros::Subscriber record_sub = nh.subscribe<laser_loop_closure::LoopClosure>(
      "/esdf_backend/loop_records", 5000, [&](const laser_loop_closure::LoopClosure::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        llc::LoopRecord record;
        record.loop = llc_ros::fromLoopClosureMsg(*m);
        record.applied = m->accepted;
        seen.records.push_back(record);
        touch();
      });
  ros::Subscriber path_sub = nh.subscribe<nav_msgs::Path>("/path", 100, [&](const nav_msgs::Path::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.path_sizes.push_back(m->poses.size());
    touch();
  });
  ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>("/tf", 1000, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    for (const auto& t : m->transforms) {
      if (t.header.frame_id == "odom" && t.child_frame_id == "base_link") {
        ++seen.odom_to_base;
        seen.newest_odom_to_base = t;
      }
      if (t.header.frame_id != "map" || t.child_frame_id != "odom") continue;
      seen.newest_map_to_odom = t;
      ++seen.map_to_odom;
      if (t.header.stamp > ros::Time::now()) ++seen.map_to_odom_future;
      const ros::WallTime now = ros::WallTime::now();
      // From the first keyframe until the drive is over (the player ends; then the clock stops).
      if (!seen.last_map_to_odom.isZero() && !seen.keyframe_stamps.empty() && (now - seen.last_message).toSec() < 2.0) {
        const double gap = (now - seen.last_map_to_odom).toSec();
        seen.map_to_odom_max_gap = std::max(seen.map_to_odom_max_gap, gap);
        seen.map_to_odom_long_gaps += gap > 0.1;
      }
      seen.last_map_to_odom = now;
      if (!seen.last_map_to_odom_stamp.isZero() && !seen.keyframe_stamps.empty()) {
        const double stamp_gap = (t.header.stamp - seen.last_map_to_odom_stamp).toSec();
        seen.map_to_odom_max_stamp_gap = std::max(seen.map_to_odom_max_stamp_gap, stamp_gap);
        seen.map_to_odom_long_stamp_gaps += stamp_gap > 0.4;
      }
      seen.last_map_to_odom_stamp = t.header.stamp;
    }
  });

  const llc_test::HealthWatch front_end_health(nh, "loop closure");
  // Follows /map from the start by its parts (/map_updates), as rviz does.
  const llc_test::MapFollower follower(nh);

  ros::AsyncSpinner spinner(2);
  spinner.start();
  // The player starts paused: it goes on once the nodelets take the bag's scans and tf and
  // this node hears what they send, so that no first keyframe is lost to a slow start.
  std::string start_why;
  ASSERT_TRUE(llc_test::playWhenConnected(
      {"/scan_front", "/scan_back", "/tf_static", "/ground_truth"},
      [&] { return keyframe_sub.getNumPublishers() > 0 && record_sub.getNumPublishers() > 0 && path_sub.getNumPublishers() > 0; },
      300.0, &start_why))
      << start_why;
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < max_wall_seconds) {
    ros::WallDuration(1.0).sleep();
    std::lock_guard<std::mutex> lock(seen.mutex);
    if (!seen.keyframe_stamps.empty() && (ros::WallTime::now() - seen.last_message).toSec() > quiet_seconds) break;
  }

  // The front end's health after the drive (told every second of wall time).
  ros::WallDuration(1.5).sleep();
  // The map settles (keyframes moved by the last loops are drawn a bounded number per update).
  const ros::WallTime settling = ros::WallTime::now();
  while (follower.quietSeconds() < 8.0 && (ros::WallTime::now() - settling).toSec() < 120.0) ros::WallDuration(0.5).sleep();
  const nav_msgs::OccupancyGrid followed = follower.grid();
  const std::size_t wholes_followed = follower.wholes();
  // A subscriber that comes after the map was published still gets it: a new subscriber (in
  // another process: one in this process would share the follower's connection) makes the back
  // end send /map whole, to every subscriber.
  const ros::WallTime resent = ros::WallTime::now();
  const std::string late_log = "/tmp/llc_bag_run_late_map_" + std::to_string(getpid()) + ".log";
  std::string late_output;
  {
    llc_test::ChildProcess late_subscriber({"rostopic", "echo", "-n", "1", "/map/info"}, late_log);
    while ((follower.wholes() == wholes_followed || !late_subscriber.ended()) && (ros::WallTime::now() - resent).toSec() < 60.0)
      ros::WallDuration(0.2).sleep();
    late_output = late_subscriber.tail();
  }
  std::remove(late_log.c_str());
  const std::size_t map_wholes = follower.wholes(), map_parts = follower.parts();
  const nav_msgs::OccupancyGrid whole_again = follower.grid();
  spinner.stop();

  std::lock_guard<std::mutex> lock(seen.mutex);
  const std::size_t keyframes = seen.keyframe_stamps.size();
  ASSERT_GT(keyframes, 100u) << "the front end made too few keyframes";
  EXPECT_NE(late_output.find("width: "), std::string::npos) << "no /map for a late subscriber: " << late_output;
  // The map followed by its parts is the map sent whole: no part lost or misplaced.
  EXPECT_GT(map_parts, 10u) << "/map_updates sent no parts";
  EXPECT_EQ(follower.misfits(), 0u) << "parts outside the whole map";
  EXPECT_GT(map_wholes, wholes_followed) << "no whole /map for a new subscriber";
  EXPECT_GT(std::size_t(whole_again.info.width) * whole_again.info.height, 10000u);
  EXPECT_EQ(followed.info.width, whole_again.info.width);
  EXPECT_EQ(followed.info.height, whole_again.info.height);
  EXPECT_EQ(followed.info.origin.position.x, whole_again.info.origin.position.x);
  std::size_t cells_differing = 0;
  for (std::size_t i = 0; i < std::min(followed.data.size(), whole_again.data.size()); ++i)
    cells_differing += followed.data[i] != whole_again.data[i];
  EXPECT_EQ(cells_differing, 0u) << "of " << whole_again.data.size();
  RecordProperty("map_wholes", int(map_wholes));
  RecordProperty("map_parts", int(map_parts));
  EXPECT_GT(seen.map_to_odom, 100u) << "map -> odom not on /tf";
  EXPECT_GT(seen.map_to_odom_future, seen.map_to_odom / 2) << "map -> odom is not dated ahead (transform_tolerance)";
  // Broadcast every 0.05 s of the ROS clock (12.5 ms of wall time at 4x). Gaps between
  // broadcasts are recorded, not asserted: they measure the machine as much as the node.
  // With the broadcast put back on the back end's main queue (a one-off edit), one run alone
  // had 31 wall-time gaps over 0.1 s and 29 stamp gaps over 0.4 s (the longest 2.36 s of ROS
  // time); with its own thread 0 and 0 alone, but 23-48 and 14-31 beside a CPU-heavy job on
  // this 2-core machine, so no bound separates a held-back broadcast from a busy machine.
  ASSERT_GE(seen.path_sizes.size(), 10u);
  for (std::size_t i = 1; i < seen.path_sizes.size(); ++i) EXPECT_GE(seen.path_sizes[i], seen.path_sizes[i - 1]);
  EXPECT_EQ(seen.path_sizes.back(), keyframes) << "the path must end with one pose per keyframe";

  std::vector<llc::Pose2> truth;
  for (double stamp : seen.keyframe_stamps) truth.push_back(truthAt(seen.truth, stamp));
  const llc::LoopTruthCheck check = llc::checkLoopsAgainstTruth(truth, seen.keyframe_full_circle, seen.records);
  // In the rostest's XML result (scripts/test prints them).
  RecordProperty("keyframes", int(keyframes));
  RecordProperty("loops_applied", int(check.applied));
  RecordProperty("true_loop_keyframes", int(check.true_loop_keyframes));
  RecordProperty("true_loop_keyframes_closed", int(check.closed));
  RecordProperty("wrong_loops_applied", int(check.wrong_loops));
  RecordProperty("path_messages", int(seen.path_sizes.size()));
  RecordProperty("map_to_odom_broadcasts", int(seen.map_to_odom));
  RecordProperty("map_to_odom_max_gap_wall_s", std::to_string(seen.map_to_odom_max_gap));
  RecordProperty("map_to_odom_gaps_over_0_1s", int(seen.map_to_odom_long_gaps));
  RecordProperty("map_to_odom_max_stamp_gap_s", std::to_string(seen.map_to_odom_max_stamp_gap));
  RecordProperty("map_to_odom_stamp_gaps_over_0_4s", int(seen.map_to_odom_long_stamp_gaps));
  // How far the front end fell behind the scans, and what it dropped (0 on an idle machine).
  ASSERT_TRUE(front_end_health.seen()) << "no diagnostics from loop_closure";
  RecordProperty("front_end_largest_lag_s", std::to_string(front_end_health.value("largest lag (s)")));
  RecordProperty("scans_dropped_to_catch_up", int(front_end_health.value("scans dropped to catch up (max_lag)")));
  RecordProperty("scans_dropped_queue_full", int(front_end_health.value("scans dropped, queue full (queue_size)")));
  RecordProperty("scans_without_wheel_odometry", int(front_end_health.value("scans without wheel odometry")));
  RecordProperty("scans_received", int(front_end_health.value("scans received")));
  RecordProperty("scans_processed", int(front_end_health.value("scans processed")));
  RecordProperty("scan_callback_longest_ms", std::to_string(front_end_health.value("scan callbacks: longest (ms)")));
  RecordProperty("scan_arrival_to_processed_longest_ms",
                 std::to_string(front_end_health.value("scan arrival to processed: longest (ms)")));
  ASSERT_GT(check.true_loop_keyframes, 20u);
  EXPECT_GE(double(check.closed), 0.8 * double(check.true_loop_keyframes));
  EXPECT_EQ(check.wrong_loops, 0u);

  if (laser_only) {
    // Scan matching's odom -> base_link and the back end's map -> odom put the robot where it
    // was: the map frame is the first keyframe's pose, so compare with the truth from there.
    RecordProperty("odom_to_base_broadcasts", int(seen.odom_to_base));
    ASSERT_GT(seen.odom_to_base, 100u) << "odom -> base_link not on /tf from scan matching";
    const llc::Pose2 map_to_base = llc::compose(planar(seen.newest_map_to_odom.transform),
                                                planar(seen.newest_odom_to_base.transform));
    const llc::Pose2 truth_to_base = llc::between(truthAt(seen.truth, seen.keyframe_stamps.front()),
                                                  truthAt(seen.truth, seen.newest_odom_to_base.header.stamp.toSec()));
    const double error = std::hypot(map_to_base.x - truth_to_base.x, map_to_base.y - truth_to_base.y);
    RecordProperty("final_pose_error_m", std::to_string(error));
    EXPECT_LT(error, 1.0) << "map -> base_link at the end of the drive is off the truth";  // 0.24 m when written
  }
  if (!services) return;

  // ~train_classifier on the session: keyframes labelled by their optimised poses (the path).
  char folder[] = "/tmp/llc_bag_run_XXXXXX";
  ASSERT_NE(mkdtemp(folder), nullptr);
  // Every call is bounded in wall time (the clock stopped with the bag): an unanswered call
  // fails the test instead of hanging it.
  std::string why;
  double took = 0.0;
  laser_loop_closure::TrainClassifier train;
  train.request.model_path = std::string(folder) + "/session_model.yaml";
  ASSERT_TRUE(llc_test::callWithin("/loop_closure/train_classifier", &train, train_wall_seconds, &why, &took)) << why;
  RecordProperty("train_session_wall_s", std::to_string(took));
  const auto& trained = train.response;
  RecordProperty("train_session_pairs", int(trained.pairs));
  RecordProperty("train_session_detection", std::to_string(trained.detection));
  RecordProperty("train_session_running_detection", std::to_string(trained.running_detection));
  RecordProperty("train_session_swapped", int(trained.swapped));
  ASSERT_TRUE(trained.success) << trained.message;
  EXPECT_GE(trained.pairs, 200u) << trained.message;
  EXPECT_EQ(trained.swapped, trained.detection >= trained.running_detection) << trained.message;
  EXPECT_NO_THROW(llc::loadClassifierModel(train.request.model_path));

  // ~save_session, then ~load_session of it: the front end gets the keyframes on /session.
  laser_loop_closure::SaveSession save;
  save.request.path = std::string(folder) + "/run.llcsession";
  ASSERT_TRUE(llc_test::callWithin("/esdf_backend/save_session", &save, 5.0, &why)) << why;
  ASSERT_TRUE(save.response.success) << save.response.message;
  EXPECT_EQ(save.response.keyframes, keyframes);
  const llc::SlamSession saved = llc::loadSession(save.request.path);
  ASSERT_EQ(saved.keyframes.size(), keyframes);
  EXPECT_EQ(saved.features.front().size(), llc::featureCount(llc::FeatureSet::kExtended));
  EXPECT_EQ(saved.constraints.size(), keyframes - 1 + check.applied);
  // Saved at bounded size (prune): one keyframe per place and heading kept, and it rebuilds.
  laser_loop_closure::SaveSession pruned_save;
  pruned_save.request.path = std::string(folder) + "/run_pruned.llcsession";
  pruned_save.request.prune = true;
  ASSERT_TRUE(llc_test::callWithin("/esdf_backend/save_session", &pruned_save, 30.0, &why)) << why;
  ASSERT_TRUE(pruned_save.response.success) << pruned_save.response.message;
  const llc::SlamSession pruned = llc::loadSession(pruned_save.request.path);
  EXPECT_EQ(pruned.keyframes.size(), std::size_t(pruned_save.response.keyframes));
  EXPECT_LT(pruned.keyframes.size(), keyframes) << "keyframes 1.4 m apart share 2 m places";
  EXPECT_GT(pruned.keyframes.size(), keyframes / 4);
  llc::SlamBackEnd restored;
  EXPECT_EQ(restored.restore(pruned), "") << "the pruned session does not rebuild a back end";
  RecordProperty("pruned_session_keyframes", int(pruned.keyframes.size()));
  laser_loop_closure::LoadSession load;
  load.request.path = std::string(folder) + "/none.llcsession";
  ASSERT_TRUE(llc_test::callWithin("/esdf_backend/load_session", &load, 5.0, &why)) << why;
  EXPECT_FALSE(load.response.success);
  EXPECT_NE(load.response.message.find("none.llcsession"), std::string::npos) << load.response.message;
  load.request.path = save.request.path;
  // The session reaches the front end in parts of at most session_part_keyframes (100) keyframes.
  std::vector<laser_loop_closure::Session::ConstPtr> parts;
  ros::CallbackQueue session_queue;
  ros::NodeHandle session_nh;
  session_nh.setCallbackQueue(&session_queue);
  ros::Subscriber session_sub = session_nh.subscribe<laser_loop_closure::Session>(
      "/session", 1000, [&](const laser_loop_closure::Session::ConstPtr& m) { parts.push_back(m); });
  const llc_test::HealthWatch restoring_front_end(session_nh, "loop closure");  // on session_queue
  const ros::WallTime subscribed_by = ros::WallTime::now() + ros::WallDuration(10.0);
  while (session_sub.getNumPublishers() == 0 && ros::WallTime::now() < subscribed_by) ros::WallDuration(0.05).sleep();
  ASSERT_TRUE(llc_test::callWithin("/esdf_backend/load_session", &load, 5.0, &why)) << why;
  ASSERT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(load.response.keyframes, keyframes);
  const std::size_t expected_parts = (keyframes + 99) / 100;
  const ros::WallTime parts_by = ros::WallTime::now() + ros::WallDuration(20.0);
  while (parts.size() < expected_parts && ros::WallTime::now() < parts_by) session_queue.callAvailable(ros::WallDuration(0.05));
  ASSERT_EQ(parts.size(), expected_parts) << "parts of the session on /session after ~load_session";
  std::size_t keyframes_in_parts = 0;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    EXPECT_EQ(parts[p]->part, p);
    EXPECT_EQ(parts[p]->parts, expected_parts);
    EXPECT_EQ(parts[p]->first_keyframe, keyframes_in_parts);
    EXPECT_LE(parts[p]->keyframes.size(), 100u);
    keyframes_in_parts += parts[p]->keyframes.size();
  }
  EXPECT_EQ(keyframes_in_parts, keyframes);
  EXPECT_EQ(parts.back()->keyframes.back().features.size(), saved.features.back().size());
  // The front end put them together and restored them.
  const ros::WallTime restored_by = ros::WallTime::now() + ros::WallDuration(10.0);
  while (restoring_front_end.value("keyframes of the last restored session") != double(keyframes) &&
         ros::WallTime::now() < restored_by)
    session_queue.callAvailable(ros::WallDuration(0.1));
  EXPECT_EQ(restoring_front_end.value("keyframes of the last restored session"), double(keyframes));
  RecordProperty("session_bytes", int(std::ifstream(save.request.path, std::ios::ate | std::ios::binary).tellg()));
  std::system(("rm -rf " + std::string(folder)).c_str());
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_bag_run"); }
