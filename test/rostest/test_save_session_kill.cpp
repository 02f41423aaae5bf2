// save_session against kill -9: the esdf_backend node (a process of its own, started here) is
// killed with SIGKILL while it saves a session, at a different moment each time, and the file
// at that path must then be the session that was there before or the new one, whole — never
// a torn or truncated one (the saver writes a temporary file, flushes it and renames it).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include "laser_loop_closure/LoadSession.h"
#include "laser_loop_closure/SaveSession.h"
#include "laser_loop_closure/core/slam/session_io.hpp"

extern char** environ;

namespace {

/// This test binary's folder: the package's node executables are built beside it.
std::string ownFolder() {
  char path[4096];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof path - 1);
  if (n <= 0) return ".";
  path[n] = '\0';
  std::string text(path);
  return text.substr(0, text.rfind('/'));
}

/// esdf_backend_node under its own name, killed with SIGKILL when it goes.
class BackEndProcess {
 public:
  explicit BackEndProcess(const std::string& name) {
    std::vector<std::string> words = {ownFolder() + "/esdf_backend_node", "__name:=" + name};
    std::vector<char*> argv;
    for (std::string& w : words) argv.push_back(&w[0]);
    argv.push_back(nullptr);
    started_ = posix_spawn(&pid_, argv[0], nullptr, nullptr, argv.data(), environ) == 0;
  }
  ~BackEndProcess() { killNow(); }
  bool started() const { return started_; }
  void killNow() {
    if (!started_ || reaped_) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    reaped_ = true;
  }

 private:
  pid_t pid_ = 0;
  bool started_ = false, reaped_ = false;
};

/// The keyframe count of the session at `path`, or -1 when it is not one whole session.
long wholeSession(const std::string& path) {
  try {
    return long(llc::loadSession(path).keyframes.size());
  } catch (const std::exception&) {
    return -1;
  }
}

TEST(SaveSessionKill, TheFileIsAlwaysTheOldSessionOrTheNewOneWhole) {
  ros::NodeHandle pnh("~");
  std::string session;
  int kills = 8;
  pnh.getParam("session", session);
  pnh.getParam("kills", kills);
  if (!std::ifstream(session).good()) GTEST_SKIP() << "no session at '" << session << "' (scripts/test makes it)";
  const long keyframes = wholeSession(session);
  ASSERT_GT(keyframes, 0) << session << " is not a whole session";

  char folder_template[] = "/tmp/llc_kill_XXXXXX";
  ASSERT_NE(mkdtemp(folder_template), nullptr);
  const std::string folder = folder_template, target = folder + "/saved.llcsession";
  // An old session stands at the path before every save (a copy of the one loaded): a kill
  // must leave it, or the new one, whole.
  {
    std::ifstream in(session, std::ios::binary);
    std::ofstream out(target, std::ios::binary);
    out << in.rdbuf();
  }
  int torn = 0, whole = 0, saves_finished = 0, killed_mid_write = 0;
  for (int k = 0; k < kills; ++k) {
    const std::string name = "esdf_kill_" + std::to_string(k);
    BackEndProcess node(name);
    ASSERT_TRUE(node.started()) << "could not start " << ownFolder() << "/esdf_backend_node";
    ros::ServiceClient load = ros::NodeHandle().serviceClient<laser_loop_closure::LoadSession>("/" + name + "/load_session");
    ros::ServiceClient save = ros::NodeHandle().serviceClient<laser_loop_closure::SaveSession>("/" + name + "/save_session");
    ASSERT_TRUE(load.waitForExistence(ros::Duration(60.0))) << name << " offers no load_session";
    ASSERT_TRUE(save.waitForExistence(ros::Duration(60.0))) << name << " offers no save_session";
    laser_loop_closure::LoadSession load_call;
    load_call.request.path = session;
    ASSERT_TRUE(load.call(load_call) && load_call.response.success) << load_call.response.message;
    std::remove((target + ".tmp").c_str());
    // Saving this session takes some tens of milliseconds: the kill lands before, during or
    // after the write, a little later each time.
    auto saving = std::async(std::launch::async, [&] {
      laser_loop_closure::SaveSession call;
      call.request.path = target;
      return save.call(call) && call.response.success;
    });
    ros::WallDuration(0.02 * k).sleep();
    node.killNow();
    saves_finished += saving.get();
    // A temporary left behind: the kill came while the new session was being written.
    killed_mid_write += std::ifstream(target + ".tmp").good();
    const long after = wholeSession(target);
    (after == keyframes ? whole : torn) += 1;
    EXPECT_EQ(after, keyframes) << "kill " << k << " after " << 20 * k << " ms: the file at " << target
                                << " is not a whole session";
  }
  RecordProperty("kills", kills);
  RecordProperty("saves_finished_before_the_kill", saves_finished);
  RecordProperty("kills_during_the_write", killed_mid_write);
  RecordProperty("whole_after_the_kill", whole);
  RecordProperty("torn_files", torn);
  EXPECT_EQ(torn, 0);
  std::system(("rm -rf " + folder).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_save_session_kill");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
