// Waiting in rostests with explicit bounds on wall time. ros::service::call has no timeout and
// ros::topic::waitForMessage counts its timeout on the ROS clock, which stops when a bag ends
// or is paused: either can hang a test for good. These fail with a message instead.
#pragma once

#include <gtest/gtest.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/SetBool.h>

#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace llc_test {

/// Calls `service` from a helper thread and waits at most `seconds` of wall time, including
/// the wait for the service to be advertised. True when it answered in time: `srv` then holds
/// the response and `took` the seconds the call took. False with `why` otherwise; a call that
/// did not answer is left running on its detached thread (end the process with std::_Exit).
template <class Srv>
bool callWithin(const std::string& service, Srv* srv, double seconds, std::string* why, double* took = nullptr) {
  const ros::WallTime start = ros::WallTime::now();
  const ros::WallTime deadline = start + ros::WallDuration(seconds);
  while (!ros::service::exists(service, false)) {
    if (ros::WallTime::now() > deadline) {
      *why = service + " was not advertised within " + std::to_string(seconds) + " s of wall time";
      return false;
    }
    ros::WallDuration(0.05).sleep();
  }
  struct Shared {
    std::mutex mutex;
    std::condition_variable done_signal;
    bool done = false, ok = false;
    Srv srv;
  };
  auto shared = std::make_shared<Shared>();
  shared->srv = *srv;
  std::thread([shared, service] {
    Srv local;
    {
      std::lock_guard<std::mutex> lock(shared->mutex);
      local = shared->srv;
    }
    const bool ok = ros::service::call(service, local);
    std::lock_guard<std::mutex> lock(shared->mutex);
    shared->srv = local;
    shared->ok = ok;
    shared->done = true;
    shared->done_signal.notify_all();
  }).detach();
  std::unique_lock<std::mutex> lock(shared->mutex);
  const auto remaining = std::chrono::duration<double>(std::max(0.0, (deadline - ros::WallTime::now()).toSec()));
  if (!shared->done_signal.wait_for(lock, remaining, [&] { return shared->done; })) {
    *why = service + " did not answer within " + std::to_string(seconds) + " s of wall time";
    return false;
  }
  if (took) *took = (ros::WallTime::now() - start).toSec();
  if (!shared->ok) {
    *why = "the call of " + service + " failed (the server went away, or the request did not reach it)";
    return false;
  }
  *srv = shared->srv;
  return true;
}

/// The first message on `topic` (a latched one comes at once), or null after `seconds` of
/// wall time. Spins its own queue: works whether or not the caller spins.
template <class M>
typename M::ConstPtr waitForMessageWithin(const std::string& topic, double seconds) {
  ros::CallbackQueue queue;
  ros::NodeHandle nh;
  nh.setCallbackQueue(&queue);
  typename M::ConstPtr received;
  ros::Subscriber sub = nh.subscribe<M>(topic, 1, [&](const typename M::ConstPtr& m) { received = m; });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (!received && ros::WallTime::now() < deadline) queue.callAvailable(ros::WallDuration(0.05));
  return received;
}

/// True when every topic in `topics` has a subscriber registered with the master. (That the
/// TCP link to the publisher is up is not visible here; it follows within milliseconds.)
inline bool everyTopicSubscribed(const std::vector<std::string>& topics) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", args, result, payload, false)) return false;
  const XmlRpc::XmlRpcValue& subscribers = payload[1];  // [[topic, [node, ...]], ...]
  for (const std::string& topic : topics) {
    bool found = false;
    for (int k = 0; k < subscribers.size() && !found; ++k) {
      XmlRpc::XmlRpcValue entry = subscribers[k];
      found = std::string(entry[0]) == topic && entry[1].size() > 0;
    }
    if (!found) return false;
  }
  return true;
}

/// Waits at most `seconds` of wall time until `ready()` holds, checking every 0.1 s.
template <class Ready>
bool waitUntilReady(double seconds, Ready ready) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (!ready()) {
    if (ros::WallTime::now() > deadline) return false;
    ros::WallDuration(0.1).sleep();
  }
  return true;
}

/// For a player started with --pause (node /player): waits at most `seconds` of wall time
/// until `ready()` holds and every topic of `bag_topics` has a subscriber, then lets it play
/// (its pause_playback service). A fixed start delay races a busy machine: the nodelets can
/// miss the first scans, or the test the first messages they send.
template <class Ready>
bool playWhenConnected(const std::vector<std::string>& bag_topics, Ready ready, double seconds, std::string* why) {
  if (!waitUntilReady(seconds, [&] { return ready() && everyTopicSubscribed(bag_topics); })) {
    *why = "the nodelets and the test were not connected within " + std::to_string(seconds) + " s of wall time";
    return false;
  }
  ros::WallDuration(1.0).sleep();  // the TCP links of the subscriptions just registered
  std_srvs::SetBool play;
  play.request.data = false;  // pause_playback(false): go on
  return callWithin("/player/pause_playback", &play, 60.0, why);
}

/// A rostest node's main: runs the tests, then leaves at once. A call that never answered is
/// still blocked on its thread; waiting for it at exit would hang the test after all.
inline int runTestsAndLeave(int argc, char** argv, const char* node) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, node);
  const int result = RUN_ALL_TESTS();
  std::fflush(nullptr);
  std::_Exit(result);
}

}  // namespace llc_test
