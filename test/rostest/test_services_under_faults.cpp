// rostest: the nodelets' services answer within 5 s of wall time whatever the clock does. The
// test cuts the simulated drive to its first drive_seconds and takes the wheel odometry
// (odom -> base_link on /tf) out of its last tf_ends_early seconds, then plays it with a real
// `rosbag play` that it starts itself:
//  1. mid-drive it pauses the player (its pause_playback service: /clock stands still) and
//     calls ~train_classifier, ~save_map, ~save_session and ~load_session;
//  2. it resumes, checks that mapping goes on, lets the bag end (the clock stops for good and
//     the last scans wait for odometry that never comes) and calls the four services again.
// Every wait is bounded in wall time; a call that does not answer fails the test, never hangs it.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <rosgraph_msgs/Clock.h>
#include <ros/ros.h>
#include <spawn.h>
#include <std_srvs/SetBool.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>

#include <fcntl.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/LoadSession.h"
#include "laser_loop_closure/SaveMap.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/TrainClassifier.h"
#include "health_watch.hpp"
#include "wall_bounded.hpp"

extern char** environ;

namespace {

constexpr double kAnswerSeconds = 5.0;  // what the issue asks of every service

/// The first `drive_seconds` of `in`, with every odom -> base_link transform of the last
/// `tf_ends_early` seconds left out. Returns how many scans come after the last odometry.
std::size_t writeCutBag(const std::string& in, const std::string& out, double drive_seconds, double tf_ends_early) {
  rosbag::Bag source(in, rosbag::bagmode::Read);
  rosbag::View view(source);
  const ros::Time start = view.getBeginTime(), end = start + ros::Duration(drive_seconds);
  const ros::Time odometry_end = end - ros::Duration(tf_ends_early);
  rosbag::Bag sink(out, rosbag::bagmode::Write);
  std::size_t scans_after_odometry = 0;
  for (const rosbag::MessageInstance& m : view) {
    if (m.getTime() > end) break;
    if (m.getTopic() == "/tf" && m.getTime() > odometry_end) {
      tf2_msgs::TFMessage tf = *m.instantiate<tf2_msgs::TFMessage>();
      tf.transforms.erase(std::remove_if(tf.transforms.begin(), tf.transforms.end(),
                                         [](const geometry_msgs::TransformStamped& t) { return t.child_frame_id == "base_link"; }),
                          tf.transforms.end());
      if (!tf.transforms.empty()) sink.write(m.getTopic(), m.getTime(), tf, m.getConnectionHeader());
      continue;
    }
    scans_after_odometry += m.getTopic() == "/scan_front" && m.getTime() > odometry_end;
    sink.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
  }
  return scans_after_odometry;
}

/// `rosbag play` as a child process named /player.
class Player {
 public:
  Player(const std::string& bag, double rate) {
    std::vector<std::string> words = {"rosbag", "play", "--clock", "--quiet", "-d", "1", "-r", std::to_string(rate), bag, "__name:=player"};
    std::vector<char*> argv;
    for (std::string& w : words) argv.push_back(&w[0]);
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);  // no keyboard
    started_ = posix_spawnp(&pid_, "rosbag", &actions, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~Player() {
    if (!running()) return;
    kill(pid_, SIGINT);
    for (int k = 0; k < 50 && running(); ++k) ros::WallDuration(0.1).sleep();
    if (running()) kill(pid_, SIGKILL), waitpid(pid_, nullptr, 0);
  }
  bool started() const { return started_; }
  bool running() {
    if (!started_ || exited_) return false;
    int status = 0;
    exited_ = waitpid(pid_, &status, WNOHANG) == pid_;
    return !exited_;
  }

 private:
  pid_t pid_ = 0;
  bool started_ = false, exited_ = false;
};

struct Seen {
  std::mutex mutex;
  std::size_t keyframes = 0;
  /// Keyframes published and then numbered again: a load while moving takes the map back to
  /// the session, and the front end goes on from its size (what it made since is dropped).
  std::size_t renumbered = 0;
  long last_index = -1;
  ros::WallTime last_keyframe = ros::WallTime::now();
  ros::Time clock;
};

/// Waits (wall time) until `done` holds; false after `seconds`.
template <class Done>
bool waitUntil(Seen& seen, double seconds, Done done) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(seen.mutex);
      if (done()) return true;
    }
    ros::WallDuration(0.1).sleep();
  }
  return false;
}

/// Calls the four services, each within kAnswerSeconds of wall time; `tag` names the phase.
/// expect_trained: the session has revisits enough for ~train_classifier to train a model.
void callEveryService(const std::string& folder, const std::string& tag, std::size_t keyframes_seen, bool expect_trained) {
  std::string why;
  double took = 0.0, slowest = 0.0;
  laser_loop_closure::TrainClassifier train;
  train.request.model_path = folder + "/" + tag + "_model.yaml";
  EXPECT_TRUE(llc_test::callWithin("/loop_closure/train_classifier", &train, kAnswerSeconds, &why, &took)) << tag << ": " << why;
  slowest = std::max(slowest, took);
  EXPECT_FALSE(train.response.message.empty()) << tag;
  if (expect_trained) {
    EXPECT_TRUE(train.response.success) << tag << ": " << train.response.message;
  }
  testing::Test::RecordProperty(tag + "_train_success", int(train.response.success));

  laser_loop_closure::SaveMap map;
  map.request.path = folder + "/" + tag + "_map";
  EXPECT_TRUE(llc_test::callWithin("/esdf_backend/save_map", &map, kAnswerSeconds, &why, &took)) << tag << ": " << why;
  slowest = std::max(slowest, took);
  EXPECT_TRUE(map.response.success) << tag << ": " << map.response.message;
  EXPECT_TRUE(std::ifstream(map.request.path + ".pgm").good()) << tag;

  laser_loop_closure::SaveSession save;
  save.request.path = folder + "/" + tag + ".llcsession";
  EXPECT_TRUE(llc_test::callWithin("/esdf_backend/save_session", &save, kAnswerSeconds, &why, &took)) << tag << ": " << why;
  slowest = std::max(slowest, took);
  EXPECT_TRUE(save.response.success) << tag << ": " << save.response.message;
  EXPECT_GE(save.response.keyframes, keyframes_seen) << tag << ": the back end has every keyframe the front end published";

  laser_loop_closure::LoadSession load;
  load.request.path = save.request.path;
  load.request.continue_odometry = true;  // the drive goes on from where it was saved
  EXPECT_TRUE(llc_test::callWithin("/esdf_backend/load_session", &load, kAnswerSeconds, &why, &took)) << tag << ": " << why;
  slowest = std::max(slowest, took);
  EXPECT_TRUE(load.response.success) << tag << ": " << load.response.message;
  EXPECT_EQ(load.response.keyframes, save.response.keyframes) << tag;
  testing::Test::RecordProperty(tag + "_slowest_answer_wall_s", std::to_string(slowest));
}

TEST(ServicesUnderFaults, AnswerWithinFiveSecondsWhenTheBagIsPausedAndWhenItEnds) {
  ros::NodeHandle nh, pnh("~");
  std::string sim_bag;
  double drive_seconds = 100.0, tf_ends_early = 1.0, rate = 4.0;
  int pause_after_keyframes = 100;
  pnh.getParam("bag", sim_bag);
  pnh.getParam("drive_seconds", drive_seconds);
  pnh.getParam("tf_ends_early", tf_ends_early);
  pnh.getParam("rate", rate);
  pnh.getParam("pause_after_keyframes", pause_after_keyframes);
  if (!std::ifstream(sim_bag).good()) GTEST_SKIP() << "no bag at '" << sim_bag << "' (scripts/test simulates it)";

  char folder_template[] = "/tmp/llc_services_XXXXXX";
  ASSERT_NE(mkdtemp(folder_template), nullptr);
  const std::string folder = folder_template;
  const std::string bag = folder + "/cut.bag";
  const std::size_t scans_after_odometry = writeCutBag(sim_bag, bag, drive_seconds, tf_ends_early);
  ASSERT_GE(scans_after_odometry, 5u) << "the cut bag must have scans after its odometry ends";
  RecordProperty("scans_after_odometry_ends", int(scans_after_odometry));

  Seen seen;
  ros::Subscriber keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>("/keyframes", 5000, [&](const laser_loop_closure::Keyframe::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    ++seen.keyframes;
    if (long(m->index) <= seen.last_index) seen.renumbered += std::size_t(seen.last_index + 1 - long(m->index));
    seen.last_index = long(m->index);
    seen.last_keyframe = ros::WallTime::now();
  });
  ros::Subscriber clock_sub = nh.subscribe<rosgraph_msgs::Clock>("/clock", 10, [&](const rosgraph_msgs::Clock::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(seen.mutex);
    seen.clock = m->clock;
  });
  const llc_test::HealthWatch front_end_health(nh, "loop closure");
  const llc_test::HealthWatch back_end_health(nh, "esdf backend");
  ros::AsyncSpinner spinner(2);
  spinner.start();

  Player player(bag, rate);
  ASSERT_TRUE(player.started()) << "could not start rosbag play";
  ASSERT_TRUE(waitUntil(seen, 300.0, [&] { return seen.keyframes >= std::size_t(pause_after_keyframes); }))
      << "only " << seen.keyframes << " keyframes in 300 s of wall time";

  // 1. Paused mid-drive: the player keeps publishing the same /clock.
  std::string why;
  std_srvs::SetBool pause;
  pause.request.data = true;
  ASSERT_TRUE(llc_test::callWithin("/player/pause_playback", &pause, kAnswerSeconds, &why)) << why;
  ros::WallDuration(1.0).sleep();
  ros::Time paused_clock;
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    paused_clock = seen.clock;
  }
  ros::WallDuration(1.0).sleep();
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    EXPECT_EQ(seen.clock, paused_clock) << "the clock moved while the player was paused";
  }
  std::size_t keyframes_at_pause = 0;
  // The front end may still finish scans it had: let the back end take them.
  waitUntil(seen, 20.0, [&] { return (ros::WallTime::now() - seen.last_keyframe).toSec() > 2.0; });
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    keyframes_at_pause = seen.keyframes;
  }
  RecordProperty("keyframes_at_pause", int(keyframes_at_pause));
  // Mid-drive the session has no revisit yet: ~train_classifier answers that it cannot train.
  callEveryService(folder, "paused", keyframes_at_pause, false);

  // Resumed: mapping goes on after the load (continue_odometry) with the keyframes after it.
  pause.request.data = false;
  ASSERT_TRUE(llc_test::callWithin("/player/pause_playback", &pause, kAnswerSeconds, &why)) << why;
  EXPECT_TRUE(waitUntil(seen, 120.0, [&] { return seen.keyframes >= keyframes_at_pause + 20; }))
      << "mapping did not go on after the pause (" << seen.keyframes << " keyframes)";

  // A load while the robot maps: the front end takes the session in when it comes, and
  // keyframes it made before are refused; then mapping goes on and the back end's health says
  // so (before: ERROR "keyframe N arrived, M expected" for the rest of the run).
  laser_loop_closure::SaveSession save_moving;
  save_moving.request.path = folder + "/moving.llcsession";
  EXPECT_TRUE(llc_test::callWithin("/esdf_backend/save_session", &save_moving, kAnswerSeconds, &why)) << why;
  laser_loop_closure::LoadSession load_moving;
  load_moving.request.path = save_moving.request.path;
  load_moving.request.continue_odometry = true;
  EXPECT_TRUE(llc_test::callWithin("/esdf_backend/load_session", &load_moving, kAnswerSeconds, &why)) << why;
  EXPECT_TRUE(load_moving.response.success) << load_moving.response.message;
  std::size_t keyframes_at_moving_load = 0;
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    keyframes_at_moving_load = seen.keyframes;
  }
  EXPECT_TRUE(waitUntil(seen, 120.0, [&] { return seen.keyframes >= keyframes_at_moving_load + 20; }))
      << "mapping did not go on after a load while moving (" << seen.keyframes << " keyframes)";
  ros::WallDuration(1.5).sleep();  // a fresh status
  EXPECT_EQ(back_end_health.value("keyframes refused since the last one taken"), 0.0)
      << "the back end's health still says the graph is stopped";
  EXPECT_NE(back_end_health.level(), int(diagnostic_msgs::DiagnosticStatus::ERROR));
  RecordProperty("keyframes_refused_by_the_load_while_moving", int(back_end_health.value("refused keyframes")));

  // 2. The bag ends; its odometry ended tf_ends_early before its scans.
  ASSERT_TRUE(waitUntil(seen, 300.0, [&] { return !player.running(); })) << "the player did not end";
  waitUntil(seen, 60.0, [&] { return (ros::WallTime::now() - seen.last_keyframe).toSec() > 5.0; });
  ros::WallDuration(1.5).sleep();  // diagnostics come every second of wall time, clock or not
  std::size_t keyframes_at_end = 0;
  {
    std::lock_guard<std::mutex> lock(seen.mutex);
    keyframes_at_end = seen.keyframes - seen.renumbered;  // those the map still holds
    RecordProperty("keyframes_renumbered_by_the_load_while_moving", int(seen.renumbered));
    ASSERT_TRUE(front_end_health.seen()) << "no diagnostics from loop_closure after the clock stopped";
    const double waiting = front_end_health.value("scans waiting for their odometry transform");
    RecordProperty("scans_waiting_for_odometry", int(waiting));
    // They wait in the tf filter (no thread blocked): the scans after the odometry ended.
    EXPECT_GE(waiting, 5.0);
    EXPECT_LE(waiting, double(scans_after_odometry) + 1.0);
    RecordProperty("front_end_largest_lag_s", std::to_string(front_end_health.value("largest lag (s)")));
    RecordProperty("scans_dropped_to_catch_up", int(front_end_health.value("scans dropped to catch up (max_lag)")));
  }
  RecordProperty("keyframes_at_end", int(keyframes_at_end));
  callEveryService(folder, "ended", keyframes_at_end, true);
  spinner.stop();
  std::system(("rm -rf " + folder).c_str());
}

}  // namespace

int main(int argc, char** argv) { return llc_test::runTestsAndLeave(argc, argv, "test_services_under_faults"); }
