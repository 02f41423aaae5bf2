// rostest: localize.launch on a kidnapped drive (localize_kidnap.test). Asserts what a user of
// localisation sees: the session's map latched on /map; ~status latched, lost until the first
// fix, then localized with map -> odom on /tf and /pose near where the map has each place; the
// kidnapping reported lost within 2 s of scan time; no localized pose more than 1 m off after
// that, and the robot found again; the session file untouched. Then ~relocalize makes it lost
// (searching), and a pose on /initialpose is taken as a hint. Last, a localization nodelet
// loaded into the same manager with a truncated or missing session is refused, naming the
// file, and every nodelet of the package loads and unloads, while the running one and the
// manager go on.
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "laser_loop_closure/LocalizationStatus.h"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/slam/localization_evaluation.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "wall_bounded.hpp"

namespace {

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

llc::Pose2 nearestInTime(const std::map<double, llc::Pose2>& poses, double stamp) {
  auto after = poses.lower_bound(stamp);
  if (after == poses.end()) return std::prev(after)->second;
  if (after == poses.begin() || std::abs(after->first - stamp) < std::abs(std::prev(after)->first - stamp)) return after->second;
  return std::prev(after)->second;
}

/// The session's keyframes with their true poses from the bag it was mapped from.
llc::MapWithTruth mapWithTruth(const llc::SlamSession& session, const std::string& map_bag) {
  std::map<double, llc::Pose2> truth;
  for (const llc::LoggedScan& scan : llc_ros::readBagSequence(map_bag).scans) truth[scan.stamp] = scan.truth;
  llc::MapWithTruth map;
  map.poses = session.poses;
  for (const llc::Keyframe& k : session.keyframes) map.truth.push_back(nearestInTime(truth, k.scan.stamp));
  llc::alignedRmsError(map.poses, map.truth, &map.truth_from_map);
  return map;
}

struct Observed {
  std::mutex mutex;
  std::map<double, llc::Pose2> truth;  ///< of the drive, by stamp
  double kidnap_stamp = -1.0;          ///< the first truth after a jump of more than 5 m
  std::vector<laser_loop_closure::LocalizationStatus> statuses;
  std::map<double, llc::Pose2> poses;  ///< /pose, by stamp
  std::size_t poses_with_covariance = 0;
  std::size_t map_to_odom = 0;
  ros::WallTime last_message = ros::WallTime::now();
};

TEST(LocalizeKidnap, LostWithinTwoSecondsAndFoundAgainWithNoPoseFarOff) {
  ros::NodeHandle nh, pnh("~");
  std::string bag, map_bag, session_path;
  pnh.getParam("bag", bag);
  pnh.getParam("map_bag", map_bag);
  pnh.getParam("session", session_path);
  for (const std::string& file : {bag, map_bag, session_path})
    if (!std::ifstream(file).good()) GTEST_SKIP() << "no file at '" << file << "' (scripts/test makes it)";
  double quiet_seconds = 15.0, max_wall_seconds = 700.0;
  pnh.getParam("quiet_seconds", quiet_seconds);
  pnh.getParam("max_wall_seconds", max_wall_seconds);
  const std::string session_before = fileBytes(session_path);
  const llc::MapWithTruth map = mapWithTruth(llc::loadSession(session_path), map_bag);

  Observed seen;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("/ground_truth", 5000, [&](const nav_msgs::Odometry::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    const llc::Pose2 pose = llc_ros::toPose2(m->pose.pose);
    if (!seen.truth.empty() && seen.kidnap_stamp < 0.0) {
      const llc::Pose2& last = seen.truth.rbegin()->second;
      if (std::hypot(pose.x - last.x, pose.y - last.y) > 5.0) seen.kidnap_stamp = m->header.stamp.toSec();
    }
    seen.truth[m->header.stamp.toSec()] = pose;
    seen.last_message = ros::WallTime::now();
  });
  ros::Subscriber status_sub = nh.subscribe<laser_loop_closure::LocalizationStatus>(
      "/localization/status", 5000, [&](const laser_loop_closure::LocalizationStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.statuses.push_back(*m);
        seen.last_message = ros::WallTime::now();
      });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "/pose", 5000, [&](const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        EXPECT_EQ(m->header.frame_id, "map");
        seen.poses[m->header.stamp.toSec()] = llc_ros::toPose2(m->pose.pose);
        seen.poses_with_covariance += m->pose.covariance[0] > 0.0 && m->pose.covariance[7] > 0.0 && m->pose.covariance[35] > 0.0;
      });
  ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>("/tf", 1000, [&](const tf2_msgs::TFMessage::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    for (const auto& t : m->transforms) seen.map_to_odom += t.header.frame_id == "map" && t.child_frame_id == "odom";
  });
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // Before any scan: the saved map, and the state, both latched.
  const nav_msgs::OccupancyGrid::ConstPtr grid = llc_test::waitForMessageWithin<nav_msgs::OccupancyGrid>("/map", 120.0);
  ASSERT_NE(grid, nullptr) << "no latched /map from the session";
  EXPECT_EQ(grid->header.frame_id, "map");
  EXPECT_GT(grid->info.width * grid->info.height, 10000u);
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected({"/scan_front", "/scan_back", "/tf_static", "/ground_truth"},
                                          [&] { return status_sub.getNumPublishers() > 0 && pose_sub.getNumPublishers() > 0; },
                                          300.0, &why))
      << why;
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < max_wall_seconds) {
    ros::WallDuration(1.0).sleep();
    std::lock_guard<std::mutex> lock(seen.mutex);
    if (!seen.truth.empty() && (ros::WallTime::now() - seen.last_message).toSec() > quiet_seconds) break;
  }

  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    ASSERT_GT(seen.kidnap_stamp, 0.0) << "the bag has no kidnapping (a jump of the truth)";
    ASSERT_FALSE(seen.statuses.empty());
    EXPECT_EQ(seen.statuses.front().state, "lost") << "a state before the first fix must be lost";
    // The first fix, before the kidnapping.
    double fixed_at = -1.0, lost_at = -1.0, found_again_at = -1.0;
    for (const laser_loop_closure::LocalizationStatus& s : seen.statuses) {
      const double t = s.header.stamp.toSec();
      if (fixed_at < 0.0 && s.state == "localized") fixed_at = t;
      if (lost_at < 0.0 && t >= seen.kidnap_stamp && s.state == "lost") lost_at = t;
      if (lost_at > 0.0 && found_again_at < 0.0 && t > lost_at && s.state == "localized") found_again_at = t;
    }
    ASSERT_GT(fixed_at, 0.0) << "never localized";
    ASSERT_LT(fixed_at, seen.kidnap_stamp) << "not localized before the kidnapping";
    ASSERT_GT(lost_at, 0.0) << "the kidnapping was never reported";
    EXPECT_LE(lost_at - seen.kidnap_stamp, 2.0) << "lost reported " << lost_at - seen.kidnap_stamp << " s after the kidnapping";
    EXPECT_GT(found_again_at, 0.0) << "not found again after the kidnapping";
    const laser_loop_closure::LocalizationStatus& last = seen.statuses.back();
    EXPECT_GE(last.relocalizations, 1u);
    EXPECT_GE(last.lost_events, 1u);
    // Every pose against where the map has its place: before the kidnapping and after it was
    // noticed (in between, the robot is not where it thinks: that is what it must notice).
    std::vector<llc::LocalizedScan> before, after;
    for (const auto& [stamp, pose] : seen.poses) {
      if (stamp >= seen.kidnap_stamp && stamp <= lost_at) continue;
      llc::LocalizedScan scan;
      scan.localized = true;
      scan.pose = pose;
      scan.truth = nearestInTime(seen.truth, stamp);
      (stamp < seen.kidnap_stamp ? before : after).push_back(scan);
    }
    ASSERT_GT(before.size(), 50u);
    ASSERT_GT(after.size(), 50u);
    const llc::LocalizationScore score_before = llc::scoreLocalization(before, map), score_after = llc::scoreLocalization(after, map);
    EXPECT_EQ(score_before.wrong_poses, 0u) << "largest error " << score_before.max_m << " m";
    EXPECT_EQ(score_after.wrong_poses, 0u) << "largest error " << score_after.max_m << " m";
    EXPECT_LT(score_before.rms_m, 0.1);
    EXPECT_LT(score_after.rms_m, 0.1);
    EXPECT_EQ(seen.poses_with_covariance, seen.poses.size()) << "a /pose without a covariance";
    EXPECT_GT(seen.map_to_odom, 100u) << "map -> odom not on /tf";
    RecordProperty("lost_after_s", std::to_string(lost_at - seen.kidnap_stamp));
    RecordProperty("first_fix_s", std::to_string(fixed_at - seen.truth.begin()->first));
    RecordProperty("poses", int(seen.poses.size()));
    RecordProperty("rms_before_m", std::to_string(score_before.rms_m));
    RecordProperty("rms_after_m", std::to_string(score_after.rms_m));
  }

  // ~relocalize: lost at once, searching the whole map; a hint on /initialpose is taken.
  const std::size_t statuses_before = seen.statuses.size();
  std_srvs::Trigger relocalize;
  ASSERT_TRUE(llc_test::callWithin("/localization/relocalize", &relocalize, 60.0, &why)) << why;
  EXPECT_TRUE(relocalize.response.success);
  ASSERT_TRUE(llc_test::waitUntilReady(30.0, [&] {
    std::lock_guard<std::mutex> lock(seen.mutex);
    return seen.statuses.size() > statuses_before;
  })) << "~relocalize sent no status";
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    EXPECT_EQ(seen.statuses.back().state, "lost");
    EXPECT_NE(seen.statuses.back().why.find("relocalize"), std::string::npos) << seen.statuses.back().why;
    EXPECT_FALSE(seen.statuses.back().hinted);
  }
  ros::Publisher hint_pub = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("/initialpose", 1, true);
  geometry_msgs::PoseWithCovarianceStamped hint;
  hint.header.frame_id = "map";
  hint.pose.pose = llc_ros::toPoseMsg(seen.poses.rbegin()->second);
  hint.pose.covariance[0] = hint.pose.covariance[7] = 0.25;
  hint_pub.publish(hint);
  EXPECT_TRUE(llc_test::waitUntilReady(30.0, [&] {
    std::lock_guard<std::mutex> lock(seen.mutex);
    return !seen.statuses.empty() && seen.statuses.back().hinted;
  })) << "the pose hint was not taken";
  spinner.stop();
  EXPECT_EQ(fileBytes(session_path), session_before) << "the saved session was altered";
}

TEST(LocalizeKidnap, ASessionThatCannotBeReadIsRefusedByNameAndTheManagerGoesOn) {
  ros::NodeHandle nh, pnh("~");
  std::string session_path;
  pnh.getParam("session", session_path);
  if (!std::ifstream(session_path).good()) GTEST_SKIP() << "no session at '" << session_path << "' (scripts/test makes it)";
  const std::string whole = fileBytes(session_path);
  const std::string truncated = "/tmp/llc_localize_kidnap_truncated_" + std::to_string(::getpid()) + ".llcsession";
  std::ofstream(truncated, std::ios::binary) << whole.substr(0, whole.size() / 2);
  const std::string missing = "/tmp/llc_localize_kidnap_missing_" + std::to_string(::getpid()) + ".llcsession";
  std::mutex mutex;
  std::vector<std::string> log_lines;
  ros::Subscriber log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::Log::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    log_lines.push_back(m->msg);
  });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Connected to every node's /rosout (the manager's above all) before anything is loaded.
  auto rosoutPublishers = [] {
    XmlRpc::XmlRpcValue args, result, payload;
    args[0] = ros::this_node::getName();
    if (!ros::master::execute("getSystemState", args, result, payload, true)) return 0;
    for (int i = 0; i < payload[0].size(); ++i)
      if (std::string(payload[0][i][0]) == "/rosout") return payload[0][i][1].size();
    return 0;
  };
  ASSERT_TRUE(llc_test::waitUntilReady(30.0, [&] {
    const int publishers = rosoutPublishers();
    return publishers > 1 && int(log_sub.getNumPublishers()) >= publishers;
  })) << "not connected to every publisher of /rosout";
  // The manager's load_nodelet fails the call itself when the nodelet does not load.
  auto loadNodelet = [&](const std::string& name, const std::string& type) {
    nodelet::NodeletLoad srv;
    srv.request.name = "/" + name;
    srv.request.type = type;
    std::string why;
    return llc_test::callWithin("/llc_manager/load_nodelet", &srv, 120.0, &why) && srv.response.success;
  };
  auto load = [&](const std::string& name, const std::string& session) {
    ros::param::set("/" + name + "/map_session", session);
    return loadNodelet(name, "laser_loop_closure/Localization");
  };
  auto unload = [&](const std::string& name) {
    nodelet::NodeletUnload srv;
    srv.request.name = "/" + name;
    std::string why;
    EXPECT_TRUE(llc_test::callWithin("/llc_manager/unload_nodelet", &srv, 60.0, &why)) << why;
    return bool(srv.response.success);
  };
  auto logged = [&](const std::string& text) {
    return llc_test::waitUntilReady(30.0, [&] {
      std::lock_guard<std::mutex> lock(mutex);
      for (const std::string& line : log_lines)
        if (line.find(text) != std::string::npos) return true;
      return false;
    });
  };
  EXPECT_FALSE(load("truncated_localization", truncated)) << "a truncated session was loaded";
  EXPECT_TRUE(logged(truncated)) << "no log line names " << truncated;
  EXPECT_FALSE(load("missing_localization", missing)) << "a missing session was loaded";
  EXPECT_TRUE(logged(missing)) << "no log line names " << missing;
  // The same parameters with the real session load: the refusals above were the sessions'.
  EXPECT_TRUE(load("second_localization", session_path));
  EXPECT_TRUE(unload("second_localization"));
  // Every nodelet of the package loads with its defaults and unloads, and the manager lives on
  // (a handle outliving its callback thread's queue once aborted the manager on unload).
  for (const char* type : {"laser_loop_closure/ScanMerger", "laser_loop_closure/LoopClosure", "laser_loop_closure/EsdfBackend"}) {
    const std::string name = std::string("unload_check_") + std::string(type).substr(std::string(type).find('/') + 1);
    EXPECT_TRUE(loadNodelet(name, type)) << type;
    EXPECT_TRUE(unload(name)) << type;
  }
  std::string why;
  nodelet::NodeletList list;
  ASSERT_TRUE(llc_test::callWithin("/llc_manager/list", &list, 30.0, &why)) << why;
  EXPECT_NE(std::find(list.response.nodelets.begin(), list.response.nodelets.end(), "/localization"), list.response.nodelets.end())
      << "the running localization nodelet is gone";
  EXPECT_EQ(std::find(list.response.nodelets.begin(), list.response.nodelets.end(), "/truncated_localization"),
            list.response.nodelets.end());
  std_srvs::Trigger relocalize;
  EXPECT_TRUE(llc_test::callWithin("/localization/relocalize", &relocalize, 60.0, &why)) << why;
  spinner.stop();
  std::remove(truncated.c_str());
  EXPECT_EQ(fileBytes(session_path), whole) << "the saved session was altered";
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_localize_kidnap"); }
