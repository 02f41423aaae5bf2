// A command started from a rostest (roslaunch, rosbag play) on the test's own master, its
// output to a file, in a process group of its own, stopped as a user stops it in a terminal:
// SIGINT to the group, then SIGKILL to the group when it does not end within a bound of wall
// time (so no node roslaunch started outlives the test).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace llc_test {

class ChildProcess {
 public:
  /// Starts `words` (found on PATH) with stdout and stderr to `log_path`.
  ChildProcess(std::vector<std::string> words, std::string log_path) : log_path_(std::move(log_path)) {
    std::vector<char*> argv;
    for (std::string& w : words) argv.push_back(&w[0]);
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attributes, 0);  // a group of its own, led by the child
    started_ = posix_spawnp(&pid_, argv[0], &actions, &attributes, argv.data(), environ) == 0;
    posix_spawnattr_destroy(&attributes);
    posix_spawn_file_actions_destroy(&actions);
  }
  ~ChildProcess() { stop(30.0); }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool started() const { return started_; }
  /// Whether it has ended by itself (reaped here).
  bool ended() {
    if (!started_ || reaped_) return true;
    reaped_ = waitpid(pid_, nullptr, WNOHANG) == pid_;
    return reaped_;
  }
  /// SIGINT to its group, then SIGKILL to what is left of it after `seconds` of wall time.
  void stop(double seconds) {
    if (!started_) return;
    if (!ended()) {
      kill(-pid_, SIGINT);
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
      while (!ended() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    kill(-pid_, SIGKILL);  // any node left behind (none when roslaunch shut down cleanly)
    if (!ended()) {
      waitpid(pid_, nullptr, 0);
      reaped_ = true;
    }
  }
  /// The last `lines` lines of its output (for a failure message).
  std::string tail(std::size_t lines = 30) const {
    std::ifstream in(log_path_);
    std::vector<std::string> all;
    for (std::string line; std::getline(in, line);) all.push_back(line);
    std::ostringstream out;
    for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) out << all[i] << "\n";
    return out.str();
  }

 private:
  std::string log_path_;
  pid_t pid_ = 0;
  bool started_ = false, reaped_ = false;
};

}  // namespace llc_test
