// rostest (aces_localize.test): a real bag mapped, saved and localised on, as a user does it.
// The first half of the ACES bag goes through bag.launch and ~save_session; then the second
// half is played into localize.launch on that session, from no initial pose. The localized
// poses are judged against a reference: the same pipeline run offline on the whole bag
// (SlamPipeline, the mapping that scores about Cartographer's accuracy on ACES's relations),
// with the map's frame laid onto it by the session's keyframes and each pose judged where the
// map has its place (llc::scoreLocalization). Most of ACES's second half explores corridors the
// first half never saw: the robot must fix where it is mapped and never be placed wrongly.
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/LocalizationStatus.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/geometry/trajectory_error.hpp"
#include "laser_loop_closure/core/slam/localization_evaluation.hpp"
#include "laser_loop_closure/core/slam/localizer.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "wall_bounded.hpp"

namespace {

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The pose stamped nearest to `stamp`, when one is within `tolerance` s.
const llc::Pose2* nearestInTime(const std::map<double, llc::Pose2>& poses, double stamp, double tolerance) {
  if (poses.empty()) return nullptr;
  auto after = poses.lower_bound(stamp);
  if (after == poses.end() || (after != poses.begin() && stamp - std::prev(after)->first < after->first - stamp)) --after;
  return std::abs(after->first - stamp) <= tolerance ? &after->second : nullptr;
}

/// Every scan's pose by the pipeline run offline on the whole bag, by stamp.
std::map<double, llc::Pose2> referencePoses(const std::string& bag) {
  llc_ros::BagReadOptions options;
  options.topics.front = "/scan";
  const llc::ScanSequence sequence = llc_ros::readBagSequence(bag, options);
  llc::SlamPipeline slam(llc::loadClassifierModel(ros::package::getPath("laser_loop_closure") + "/config/classifier.yaml"));
  for (std::size_t i = 0; i < sequence.scans.size(); ++i) slam.addScan(sequence.scans[i].scan, i, &sequence.scans[i].odometry);
  std::map<double, llc::Pose2> poses;
  for (const llc::ScanPose& p : slam.scanPoses()) poses[p.stamp] = p.pose;
  return poses;
}

struct Observed {
  std::mutex mutex;
  std::size_t keyframes = 0;
  std::vector<laser_loop_closure::LocalizationStatus> statuses;
  std::map<double, llc::Pose2> poses;  ///< /pose by stamp
  ros::WallTime last_message = ros::WallTime::now();
};

/// Waits (wall time) until nothing came for `quiet` s once `ready()` holds; false after `limit` s.
template <class Ready>
bool waitQuiet(Observed& seen, double quiet, double limit, Ready ready) {
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < limit) {
    ros::WallDuration(1.0).sleep();
    if (!ready()) continue;
    std::lock_guard<std::mutex> lock(seen.mutex);
    if ((ros::WallTime::now() - seen.last_message).toSec() > quiet) return true;
  }
  return false;
}

TEST(AcesLocalize, FirstHalfMappedThroughBagLaunchSecondHalfLocalizedOnIt) {
  ros::NodeHandle nh, pnh("~");
  std::string bag_path;
  double map_rate = 8.0, localize_rate = 4.0;
  pnh.getParam("bag", bag_path);
  pnh.getParam("map_rate", map_rate);
  pnh.getParam("localize_rate", localize_rate);
  if (!std::ifstream(bag_path).good()) GTEST_SKIP() << "no ACES bag at '" << bag_path << "' (../shared/data/rosbag)";
  double half = 0.0;
  tf2_msgs::TFMessage mountings;
  {
    rosbag::Bag bag(bag_path);
    rosbag::View all(bag);
    half = 0.5 * (all.getEndTime() - all.getBeginTime()).toSec();
    rosbag::View statics(bag, rosbag::TopicQuery("/tf_static"));
    for (const rosbag::MessageInstance& m : statics)
      if (const auto tf = m.instantiate<tf2_msgs::TFMessage>())
        mountings.transforms.insert(mountings.transforms.end(), tf->transforms.begin(), tf->transforms.end());
  }
  char dir_template[] = "/tmp/aces_localize.XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  const std::string session_path = dir + "/aces_first_half.llcsession";

  Observed seen;
  auto touch = [&] { seen.last_message = ros::WallTime::now(); };
  ros::Subscriber keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>("/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr&) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    ++seen.keyframes;
    touch();
  });
  ros::Subscriber status_sub = nh.subscribe<laser_loop_closure::LocalizationStatus>(
      "/localization/status", 5000, [&](const laser_loop_closure::LocalizationStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        seen.statuses.push_back(*m);
        touch();
      });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "/pose", 5000, [&](const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        if (m->header.frame_id == "map") seen.poses[m->header.stamp.toSec()] = llc_ros::toPose2(m->pose.pose);
        touch();
      });
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // 1. The first half mapped through bag.launch, and saved.
  {
    llc_test::ChildProcess mapping({"roslaunch", "laser_loop_closure", "bag.launch", "bag:=" + bag_path, "scan_front:=/scan",
                                    "rate:=" + std::to_string(map_rate), "exit_at_end:=false", "duration:=" + std::to_string(half)},
                                   dir + "/mapping.log");
    ASSERT_TRUE(mapping.started());
    const ros::WallTime start = ros::WallTime::now();
    const bool done = waitQuiet(seen, 15.0, 900.0, [&] {
      std::lock_guard<std::mutex> lock(seen.mutex);
      return seen.keyframes > 0 && (ros::WallTime::now() - start).toSec() > half / map_rate;
    });
    ASSERT_TRUE(done) << "the mapping did not go quiet\n" << mapping.tail();
    ASSERT_GT(seen.keyframes, 50u) << mapping.tail();
    laser_loop_closure::SaveSession save;
    save.request.path = session_path;
    std::string why;
    ASSERT_TRUE(llc_test::callWithin("/esdf_backend/save_session", &save, 120.0, &why)) << why;
    ASSERT_TRUE(save.response.success) << save.response.message;
    mapping.stop(60.0);
  }
  const std::string session_bytes = fileBytes(session_path);
  const llc::SlamSession session = llc::loadSession(session_path);

  // 2. The second half localised on it through localize.launch, from no initial pose (the
  // back end's /pose of the mapping is not the localizer's).
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.poses.clear();
  }
  ros::param::set("/use_sim_time", true);
  ros::Publisher static_pub = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);  // as the bag's, which -s skips
  static_pub.publish(mountings);
  llc_test::ChildProcess localizing({"roslaunch", "laser_loop_closure", "localize.launch", "map_session:=" + session_path,
                                     "scan_front:=/scan"},
                                    dir + "/localize.log");
  ASSERT_TRUE(localizing.started());
  ASSERT_NE(llc_test::waitForMessageWithin<laser_loop_closure::LocalizationStatus>("/localization/status", 120.0), nullptr)
      << "localize.launch sent no status\n" << localizing.tail();
  llc_test::ChildProcess player({"rosbag", "play", "--clock", "--quiet", "--pause", "-s", std::to_string(half), "-r",
                                 std::to_string(localize_rate), bag_path, "--topics", "/scan", "/tf", "/odom", "__name:=player"},
                                dir + "/player.log");
  std::string why;
  ASSERT_TRUE(llc_test::playWhenConnected({"/scan", "/tf"}, [] { return true; }, 120.0, &why)) << why;
  const bool done = waitQuiet(seen, 20.0, 900.0, [&] { return player.ended(); });
  ASSERT_TRUE(done) << "the localisation did not go quiet\n" << localizing.tail();
  localizing.stop(60.0);
  spinner.stop();
  EXPECT_EQ(fileBytes(session_path), session_bytes) << "localisation altered the saved session";

  // 3. Judged against the whole bag mapped offline.
  const std::map<double, llc::Pose2> reference = referencePoses(bag_path);
  llc::MapWithTruth map;
  for (std::size_t k = 0; k < session.keyframes.size(); ++k)
    if (const llc::Pose2* truth = nearestInTime(reference, session.keyframes[k].scan.stamp, 0.01)) {
      map.poses.push_back(session.poses[k]);
      map.truth.push_back(*truth);
    }
  ASSERT_GT(map.poses.size(), session.keyframes.size() / 2) << "the session's keyframes are not the bag's scans";
  const double map_rms = llc::alignedRmsError(map.poses, map.truth, &map.truth_from_map);
  std::lock_guard<std::mutex> lock(seen.mutex);
  std::vector<llc::LocalizedScan> scans;
  for (const auto& [stamp, pose] : seen.poses)
    if (const llc::Pose2* truth = nearestInTime(reference, stamp, 0.01)) scans.push_back({true, false, pose, *truth});
  ASSERT_FALSE(seen.statuses.empty());
  double first_fix = -1.0;
  for (const laser_loop_closure::LocalizationStatus& s : seen.statuses)
    if (s.state == "localized") {
      first_fix = s.path_length;
      break;
    }
  ASSERT_GE(first_fix, 0.0) << "never localized\n" << localizing.tail();
  ASSERT_GT(scans.size(), 100u) << "too few localized scans";
  // Judged where the map has keyframes within the localizer's track_radius: beyond, the robot
  // is carried by odometry (up to max_unmatched_travel) where the map has no place to judge by.
  const double judge_within = llc::LocalizerOptions{}.track_radius;
  const llc::LocalizationScore score = llc::scoreLocalization(scans, map, 1.0, 0.1, judge_within);
  {  // Beside the launches' logs, for a look after a failure.
    std::ofstream csv(dir + "/localized.csv");
    csv << "stamp,x,y,theta,reference_x,reference_y,reference_theta\n";
    for (const auto& [stamp, pose] : seen.poses)
      if (const llc::Pose2* truth = nearestInTime(reference, stamp, 0.01))
        csv << std::fixed << stamp << "," << pose.x << "," << pose.y << "," << pose.theta << "," << truth->x << "," << truth->y
            << "," << truth->theta << "\n";
    std::ofstream status_csv(dir + "/status.csv");
    status_csv << "stamp,state,fit,keyframes,why\n";
    for (const laser_loop_closure::LocalizationStatus& st : seen.statuses)
      status_csv << std::fixed << st.header.stamp.toSec() << "," << st.state << "," << st.fit << "," << st.keyframes << ",\""
                 << st.why << "\"\n";
    std::ofstream map_csv(dir + "/map.csv");
    map_csv << "x,y,theta,reference_x,reference_y,reference_theta\n";
    for (std::size_t k = 0; k < map.poses.size(); ++k)
      map_csv << std::fixed << map.poses[k].x << "," << map.poses[k].y << "," << map.poses[k].theta << "," << map.truth[k].x << ","
              << map.truth[k].y << "," << map.truth[k].theta << "\n";
  }
  RecordProperty("files", dir);
  EXPECT_GT(score.localized, 100u) << "too few localized scans near the map";
  EXPECT_EQ(score.wrong_poses, 0u) << "largest error " << score.max_m << " m";
  EXPECT_LT(score.rms_m, 0.3);
  RecordProperty("map_keyframes", int(session.keyframes.size()));
  RecordProperty("map_rms_against_reference_m", std::to_string(map_rms));
  RecordProperty("first_fix_travel_m", std::to_string(first_fix));
  RecordProperty("localized_scans", int(scans.size()));
  RecordProperty("judged_scans", int(score.localized));
  RecordProperty("beyond_map_scans", int(score.beyond_map));
  RecordProperty("rms_m", std::to_string(score.rms_m));
  RecordProperty("max_error_m", std::to_string(score.max_m));
  RecordProperty("lost_events", int(seen.statuses.back().lost_events));
  RecordProperty("fixes", int(seen.statuses.back().fixes));
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_aces_localize"); }
