#include "laser_loop_closure/ros/nodes/multi_robot_backend_ros.hpp"

#include <geometry_msgs/TransformStamped.h>
#include <ros/package.h>
#include <ros/serialization.h>
#include <std_msgs/UInt32.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/ros/io/map_publishing.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/parameters.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

std::string MultiRobotBackendNodeOptions::validate() const {
  if (map_frame.empty() || odom_frame.empty()) return "map_frame and odom_frame must not be empty";
  if (!(transform_tolerance >= 0.0)) return "transform_tolerance must not be negative";
  if (!(tf_publish_period > 0.0) || !(map_publish_period > 0.0)) return "publish periods must be positive";
  if (!(answer_timeout >= 0.0) || !(resend_wait >= 0.0)) return "answer_timeout and resend_wait must not be negative";
  if (queue_size < 1) return "queue_size must be at least 1";
  if (const std::string bad = llc::checkMapScanStep(map_scan_step); !bad.empty()) return "map_scan_step " + bad;
  if (session_path.empty() || map_path.empty()) return "session_path and map_path must not be empty";
  return "";
}

std::vector<std::string> parseRobotNames(const std::string& robots) {
  std::string spaced = robots;
  std::replace(spaced.begin(), spaced.end(), ',', ' ');
  std::istringstream in(spaced);
  std::vector<std::string> names;
  std::set<std::string> seen;
  for (std::string name; in >> name;) {
    std::string error;
    if (!ros::names::validate(name, error)) throw std::invalid_argument("robot name '" + name + "': " + error);
    if (!seen.insert(name).second) throw std::invalid_argument("robot '" + name + "' named twice");
    names.push_back(name);
  }
  if (names.empty()) throw std::invalid_argument("no robot named (parameter robots, e.g. \"r1 r2 r3\")");
  return names;
}

MultiRobotBackendRos::MultiRobotBackendRos(ros::NodeHandle nh, ros::NodeHandle private_nh) : diagnostics_(nh, private_nh) {
  loadNodeParameters(
      private_nh, "multi_robot_backend", &options_,
      [](MultiRobotBackendNodeOptions& o, ParameterReader& r) { visitMultiRobotBackendParameters(o, r); }, &system_);
  options_.map_frame = tfFrame(options_.map_frame);
  std::vector<std::string> names;
  llc::ClassifierModel model;
  try {
    names = parseRobotNames(options_.robots);
    if (options_.model_path.empty())
      options_.model_path = ros::package::getPath("laser_loop_closure") + "/config/classifier.yaml";
    model = llc::loadClassifierModel(options_.model_path);
    if (options_.map_session.empty()) {
      slam_ = std::make_unique<llc::MultiRobotSlam>(model, names.size(), system_.slam, system_.multi_robot);
    } else {  // yesterday's map of the fleet: robot 0, and every robot joins it
      const llc::SlamSession saved = llc::loadSession(options_.map_session);
      slam_ = std::make_unique<llc::MultiRobotSlam>(model, names.size() + 1, system_.slam, system_.multi_robot, &saved);
      slot_offset_ = 1;
      for (const llc::Keyframe& k : slam_->map().keyframes())
        map_scans_.push_back(llc::mapScanAtRest(k.scan, options_.map_scan_step, map_scans_.empty() ? nullptr : map_scans_.back().get()));
      map_dirty_ = true;
    }
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("multi_robot_backend: ") + e.what());
  }
  odometry_model_ = std::make_unique<llc::ScanOdometry>(system_.slam.odometry);

  robots_.resize(names.size());
  ros::NodeHandle service_nh = service_thread_.handle(private_nh);
  for (std::size_t r = 0; r < names.size(); ++r) {
    Robot& robot = robots_[r];
    robot.name = names[r];
    robot.odom_frame = tfFrame(names[r] + "/" + options_.odom_frame);
    llc::KeyframeInboxOptions inbox;
    inbox.resend_wait = options_.resend_wait;
    inbox.max_held = std::size_t(options_.queue_size);
    robot.inbox = std::make_unique<Inbox>(inbox);
    robot.path_pub = nh.advertise<nav_msgs::Path>(names[r] + "/path", 2);
    robot.resend_pub = nh.advertise<std_msgs::UInt32>(names[r] + "/resend_request", 10);
    robot.keyframe_sub = nh.subscribe<laser_loop_closure::Keyframe>(
        names[r] + "/keyframes", std::uint32_t(options_.queue_size),
        [this, r](const laser_loop_closure::Keyframe::ConstPtr& msg) { onKeyframe(r, msg); });
    robot.packed_keyframe_sub = nh.subscribe<laser_loop_closure::PackedKeyframe>(
        names[r] + "/packed_keyframes", std::uint32_t(options_.queue_size),
        [this, r](const laser_loop_closure::PackedKeyframe::ConstPtr& msg) { onPackedKeyframe(r, msg); });
    robot.loop_sub = nh.subscribe<laser_loop_closure::LoopClosure>(
        names[r] + "/loop_closures", std::uint32_t(options_.queue_size),
        [this, r](const laser_loop_closure::LoopClosure::ConstPtr& msg) { onLoop(r, msg); });
    // Each robot's front end asks its place gate and nearby keyframes of its own graph here.
    robot.place_check_srv = service_nh.advertiseService<laser_loop_closure::PlaceCheck::Request, laser_loop_closure::PlaceCheck::Response>(
        names[r] + "/place_check",
        [this, r](laser_loop_closure::PlaceCheck::Request& q, laser_loop_closure::PlaceCheck::Response& a) {
          placeCheck(r, q, a);
          countServiceBytes(r, ros::serialization::serializationLength(q) + ros::serialization::serializationLength(a));
          return true;
        });
    robot.nearby_srv = service_nh.advertiseService<laser_loop_closure::NearbyKeyframes::Request,
                                                   laser_loop_closure::NearbyKeyframes::Response>(
        names[r] + "/nearby_keyframes",
        [this, r](laser_loop_closure::NearbyKeyframes::Request& q, laser_loop_closure::NearbyKeyframes::Response& a) {
          nearbyKeyframes(r, q, a);
          countServiceBytes(r, ros::serialization::serializationLength(q) + ros::serialization::serializationLength(a));
          return true;
        });
  }
  map_updates_ = std::make_unique<MapUpdatePublisher>(nh, system_.map, options_.latch_map);
  marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("graph_markers", 1, true);
  save_session_srv_ = service_nh.advertiseService("save_session", &MultiRobotBackendRos::saveSession, this);
  save_map_srv_ = service_nh.advertiseService("save_map", &MultiRobotBackendRos::saveMap, this);
  service_thread_.start();
  if (options_.publish_tf) {
    tf_timer_ = transform_thread_.handle(nh).createTimer(ros::Duration(options_.tf_publish_period),
                                                         [this](const ros::TimerEvent&) { publishTransforms(); });
    transform_thread_.start();
  }
  map_timer_ = map_thread_.handle(nh).createWallTimer(ros::WallDuration(options_.map_publish_period),
                                                      [this](const ros::WallTimerEvent&) { publishMap(); });
  map_thread_.start();
  gap_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t r = 0; r < robots_.size(); ++r)
      if (robots_[r].inbox->held() > 0) takeHeldKeyframes(r);
  });
  diagnostics_.setHardwareID("none");
  diagnostics_.add("multi-robot backend", this, &MultiRobotBackendRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_.force_update(); });
  if (slot_offset_ == 0)
    ROS_INFO("multi_robot_backend: %zu robots (%s first: its frame is %s), model %s", names.size(), names[0].c_str(),
             options_.map_frame.c_str(), options_.model_path.c_str());
  else
    ROS_INFO("multi_robot_backend: %zu robots joining the saved map %s (%zu keyframes, its frame is %s), model %s",
             names.size(), options_.map_session.c_str(), slam_->map().keyframes().size(), options_.map_frame.c_str(),
             options_.model_path.c_str());
}

MultiRobotBackendRos::~MultiRobotBackendRos() {
  transform_thread_.stop();
  service_thread_.stop();
  map_thread_.stop();
  tf_timer_.stop();
  map_timer_.stop();
  gap_timer_.stop();
  diagnostics_timer_.stop();
}

void MultiRobotBackendRos::countBytes(Robot& robot, std::uint32_t bytes) {
  const ros::WallTime now = ros::WallTime::now();
  if (robot.bytes == 0) robot.first_message = now;
  robot.last_message = now;
  robot.bytes += bytes;
}

void MultiRobotBackendRos::countServiceBytes(std::size_t robot, std::uint32_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  countBytes(robots_[robot], bytes);
  robots_[robot].service_bytes += bytes;
}

void MultiRobotBackendRos::onPackedKeyframe(std::size_t robot, const laser_loop_closure::PackedKeyframe::ConstPtr& packed) {
  // Unpacked before the lock: other robots' messages and place checks need not wait for it.
  auto msg = boost::make_shared<laser_loop_closure::Keyframe>();
  std::string why;
  const std::uint32_t bytes = ros::serialization::serializationLength(*packed);
  if (unpackKeyframeMsg(*packed, msg.get(), &why)) return onKeyframe(robot, msg, bytes);
  std::lock_guard<std::mutex> lock(mutex_);
  Robot& r = robots_[robot];
  countBytes(r, bytes);
  ++r.keyframes_refused;  // its number stays missing, as below
  last_problem_ = r.name + ": keyframe " + std::to_string(packed->index) + ": " + why;
  ROS_WARN_THROTTLE(5.0, "multi_robot_backend: %s", last_problem_.c_str());
}

void MultiRobotBackendRos::onKeyframe(std::size_t robot, const laser_loop_closure::Keyframe::ConstPtr& msg, std::uint32_t wire_bytes) {
  // Read before the lock: other robots' messages and place checks need not wait for it.
  std::string why;
  auto arrived = std::make_shared<ArrivedKeyframe>();
  arrived->msg = msg;
  const bool readable = fromKeyframeMsg(*msg, &arrived->keyframe, &arrived->step.motion, &arrived->step.covariance, &why);
  std::lock_guard<std::mutex> lock(mutex_);
  Robot& r = robots_[robot];
  countBytes(r, wire_bytes > 0 ? wire_bytes : ros::serialization::serializationLength(*msg));
  if (!readable) {
    // Never offered: its number stays missing, and the keyframe after it bridges the gap.
    ++r.keyframes_refused;
    last_problem_ = r.name + ": keyframe " + std::to_string(msg->index) + ": " + why;
    ROS_WARN_THROTTLE(5.0, "multi_robot_backend: %s", last_problem_.c_str());
    return;
  }
  arrived->step.matched = msg->scan_matched;
  if (r.inbox->offer(msg->index, msg->loops_before, msg->header.stamp.toSec(), std::move(arrived), &why) ==
      Inbox::Offer::kRefused) {
    last_problem_ = r.name + ": " + why;
    ROS_WARN_THROTTLE(5.0, "multi_robot_backend: %s", last_problem_.c_str());
  }
  takeHeldKeyframes(robot);
}

void MultiRobotBackendRos::onLoop(std::size_t robot, const laser_loop_closure::LoopClosure::ConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot& r = robots_[robot];
  const std::uint32_t bytes = ros::serialization::serializationLength(*msg);
  countBytes(r, bytes);
  r.loop_bytes += bytes;
  if (!r.inbox->loopArrived(msg->from_keyframe, msg->to_keyframe)) return;  // sent again
  if (!takeLoop(robot, *msg)) {
    if (r.pending_loops.size() >= std::size_t(options_.queue_size)) {
      r.pending_loops.pop_front();
      ++r.loops_dropped;
    }
    r.pending_loops.push_back(*msg);
  }
  takeHeldKeyframes(robot);
  updateTransforms();
  state_changed_.notify_all();
}

void MultiRobotBackendRos::takeHeldKeyframes(std::size_t robot) {
  Robot& r = robots_[robot];
  const double now = ros::WallTime::now().toSec();
  std::optional<std::uint32_t> ask_from;
  while (auto taken = r.inbox->next(now, &ask_from)) takeKeyframe(robot, *taken);
  if (ask_from) {
    std_msgs::UInt32 request;
    request.data = *ask_from;
    r.resend_pub.publish(request);
    ROS_WARN_THROTTLE(5.0, "multi_robot_backend: %s: keyframes from %u on are missing: asked again", r.name.c_str(),
                      *ask_from);
  }
  state_changed_.notify_all();
}

void MultiRobotBackendRos::takeKeyframe(std::size_t robot, const Inbox::Taken& taken) {
  Robot& r = robots_[robot];
  const laser_loop_closure::Keyframe& msg = *taken.payload->msg;
  llc::Keyframe keyframe = taken.payload->keyframe;
  llc::OdometryStep step = taken.payload->step;
  const bool first_of_robot = slam_->robot(slot(robot)).keyframes().empty();
  if (!first_of_robot && (taken.lost_before > 0 || taken.restarted)) {
    // Keyframes lost on the way, or a front end that started again: the step from the robot's
    // odometry poses when both ends have one (a restarted front end's odometry frame is another:
    // none), with the covariance of unmatched wheels; else a new chain, placed by the loops that come.
    const bool bridged = taken.lost_before > 0 && !taken.restarted && r.has_last_wheels && keyframe.has_wheel_odometry;
    if (bridged) {
      step.motion = llc::between(r.last_wheels, keyframe.wheel_odometry);
      step.covariance = odometry_model_->stepCovariance(step.motion, false);
    } else {
      step.motion = llc::Pose2{std::nan(""), std::nan(""), std::nan("")};
    }
    step.matched = false;
    if (taken.restarted)
      ROS_WARN("multi_robot_backend: %s: its front end started again: a new chain", r.name.c_str());
    else
      ROS_WARN("multi_robot_backend: %s: %zu keyframes before %u never came: bridged by %s", r.name.c_str(),
               taken.lost_before, msg.index, bridged ? "its odometry" : "nothing (a new chain)");
  }
  r.has_last_wheels = keyframe.has_wheel_odometry;
  r.last_wheels = keyframe.wheel_odometry;
  const llc::RobotStep result = slam_->addKeyframe(slot(robot), std::move(keyframe), msg.features, step);
  if (!result.slam.back_end_note.empty())
    ROS_WARN_THROTTLE(5.0, "multi_robot_backend: %s keyframe %u: %s", r.name.c_str(), msg.index,
                      result.slam.back_end_note.c_str());
  for (std::size_t joined : result.joined_robots)
    ROS_INFO("multi_robot_backend: %s joined the map after %.1f m of its path", robots_[joined - slot_offset_].name.c_str(),
             slam_->joinedAtPath(joined));
  // Loops that waited for this keyframe.
  for (auto it = r.pending_loops.begin(); it != r.pending_loops.end();)
    it = takeLoop(robot, *it) ? r.pending_loops.erase(it) : std::next(it);
  for (std::size_t m = map_scans_.size(); m < slam_->map().keyframes().size(); ++m)
    map_scans_.push_back(llc::mapScanAtRest(slam_->map().keyframes()[m].scan, options_.map_scan_step,
                                            map_scans_.empty() ? nullptr : map_scans_.back().get()));
  map_dirty_ = true;
  updateTransforms();
}

bool MultiRobotBackendRos::takeLoop(std::size_t robot, const laser_loop_closure::LoopClosure& msg) {
  Robot& r = robots_[robot];
  if (!r.inbox->settled(msg.from_keyframe) || !r.inbox->settled(msg.to_keyframe)) return false;
  const long from = r.inbox->pipelineIndex(msg.from_keyframe), to = r.inbox->pipelineIndex(msg.to_keyframe);
  if (from < 0 || to < 0) {  // names a keyframe lost on the way (or refused)
    ++r.loops_dropped;
    return true;
  }
  llc::LoopClosure loop = fromLoopClosureMsg(msg);
  loop.from = std::size_t(from);
  loop.to = std::size_t(to);
  slam_->addLoop(slot(robot), loop);
  map_dirty_ = true;
  return true;
}

std::string MultiRobotBackendRos::waitForRobotState(std::unique_lock<std::mutex>& lock, std::size_t robot,
                                                    std::size_t keyframes, std::uint64_t loops) {
  const Robot& r = robots_[robot];
  // Wall time: the front end waits on this answer, and the clock may stand still.
  const bool reached = state_changed_.wait_for(lock, std::chrono::duration<double>(options_.answer_timeout), [&] {
    return r.inbox->expected() >= keyframes && r.inbox->loopsTaken() >= loops;
  });
  if (reached) return "";
  return r.name + ": the back end holds " + std::to_string(r.inbox->expected()) + " of its keyframes and " +
         std::to_string(r.inbox->loopsTaken()) + " loop messages, not " + std::to_string(keyframes) + " and " +
         std::to_string(loops) + ", after " + std::to_string(options_.answer_timeout) + " s";
}

bool MultiRobotBackendRos::placeCheck(std::size_t robot, laser_loop_closure::PlaceCheck::Request& request,
                                      laser_loop_closure::PlaceCheck::Response& response) {
  std::unique_lock<std::mutex> lock(mutex_);
  response.message = waitForRobotState(lock, robot, request.keyframes, request.loops);
  const long from = robots_[robot].inbox->pipelineIndex(request.from_keyframe);
  const long to = robots_[robot].inbox->pipelineIndex(request.to_keyframe);
  if (response.message.empty() && (from < 0 || to < 0)) response.message = "a keyframe of the pair never came";
  if (!response.message.empty()) return true;
  try {
    response.chi2 = slam_->placeChi2(slot(robot), std::size_t(from), std::size_t(to), request.radius);
    response.answered = true;
  } catch (const std::exception& e) {
    response.message = e.what();
  }
  return true;
}

bool MultiRobotBackendRos::nearbyKeyframes(std::size_t robot, laser_loop_closure::NearbyKeyframes::Request& request,
                                           laser_loop_closure::NearbyKeyframes::Response& response) {
  std::unique_lock<std::mutex> lock(mutex_);
  response.message = waitForRobotState(lock, robot, request.keyframes, request.loops);
  const Robot& r = robots_[robot];
  const long index = r.inbox->pipelineIndex(request.keyframe);
  if (response.message.empty() && index < 0) response.message = "keyframe " + std::to_string(request.keyframe) + " never came";
  if (!response.message.empty()) return true;
  try {
    for (const llc::NearbyKeyframe& near : slam_->nearbyKeyframes(slot(robot), std::size_t(index), r.inbox->pipelineCountBelow(request.before),
                                                                  request.max_distance, request.max_std, request.count)) {
      const std::optional<std::uint32_t> number = r.inbox->frontNumber(near.keyframe);
      if (!number) continue;  // of an earlier run of its front end: it does not know it
      response.nearby.push_back(*number);
      response.poses.push_back(toPose2D(near.pose));
    }
    response.answered = true;
  } catch (const std::exception& e) {
    response.message = e.what();
  }
  return true;
}

void MultiRobotBackendRos::updateTransforms() {
  std::vector<std::pair<std::string, llc::Pose2>> transforms;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    const auto& keyframes = slam_->robot(slot(r)).keyframes();
    if (!slam_->joined(slot(r)) || keyframes.empty() || !keyframes.back().has_wheel_odometry) continue;
    const llc::Pose2& in_map = slam_->map().poses()[slam_->mapIndex(slot(r), keyframes.size() - 1)];
    transforms.emplace_back(robots_[r].odom_frame, llc::compose(in_map, llc::inverse(keyframes.back().wheel_odometry)));
  }
  std::lock_guard<std::mutex> lock(transform_mutex_);
  map_to_odom_ = std::move(transforms);
}

void MultiRobotBackendRos::publishTransforms() {
  std::vector<std::pair<std::string, llc::Pose2>> transforms;
  {
    std::lock_guard<std::mutex> lock(transform_mutex_);
    transforms = map_to_odom_;
  }
  const ros::Time now = ros::Time::now();
  if (transforms.empty() || now.isZero() || now == last_tf_time_) return;  // tf warns about a repeated stamp
  last_tf_time_ = now;
  std::vector<geometry_msgs::TransformStamped> messages;
  for (const auto& [odom_frame, pose] : transforms) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = options_.map_frame;
    t.child_frame_id = odom_frame;
    t.header.stamp = now + ros::Duration(options_.transform_tolerance);
    t.transform = toTransformMsg(pose);
    messages.push_back(t);
  }
  tf_broadcaster_.sendTransform(messages);
}

void MultiRobotBackendRos::publishMap() {
  // A snapshot under the lock, the rebuild outside it (keyframes and place checks go on).
  std::vector<llc::Pose2> poses;
  std::vector<std::shared_ptr<const llc::CompactScan>> scans_held;
  std::vector<llc::LoopRecord> loops;
  FleetGraph fleet;
  std::vector<nav_msgs::Path> paths(robots_.size());
  std_msgs::Header header;
  header.frame_id = options_.map_frame;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_dirty_ && !map_updates_->wholeDue()) return;
    map_dirty_ = false;
    const llc::SlamBackEnd& map = slam_->map();
    poses = map.poses();
    scans_held = map_scans_;
    loops = map.loops();
    for (std::size_t m = 0; m < poses.size(); ++m) {
      const llc::RobotKeyframe& k = slam_->mapKeyframe(m);
      fleet.robot.push_back(k.robot);
      fleet.previous.push_back(k.keyframe == 0 ? m : slam_->mapIndex(k.robot, k.keyframe - 1));
    }
    if (!map.keyframes().empty()) header.stamp = ros::Time().fromSec(map.keyframes().back().stamp);
    for (std::size_t r = 0; r < robots_.size(); ++r) {
      const llc::SlamPipeline& own = slam_->robot(slot(r));
      if (own.keyframes().empty()) continue;
      std_msgs::Header path_header = header;
      std::vector<llc::Pose2> path_poses = own.poses();  // its own frame until joined
      if (slam_->joined(slot(r))) {
        for (std::size_t k = 0; k < path_poses.size(); ++k) path_poses[k] = poses[slam_->mapIndex(slot(r), k)];
      } else {
        path_header.frame_id = robots_[r].odom_frame;
      }
      paths[r] = toPathMsg(own.keyframes(), path_poses, path_header);
    }
  }
  for (std::size_t r = 0; r < robots_.size(); ++r)
    if (!paths[r].poses.empty()) robots_[r].path_pub.publish(paths[r]);
  if (poses.empty()) return;
  marker_pub_.publish(graphMarkers(poses, loops, header, fleet));
  try {
    const MapUpdatePublisher::Published published = map_updates_->publish(scans_held, poses, header);
    if (published.update.waiting > 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      map_dirty_ = true;  // the rest at the next update
    }
  } catch (const std::exception& e) {
    ROS_WARN_THROTTLE(30.0, "multi_robot_backend: map not updated: %s", e.what());
  }
}

bool MultiRobotBackendRos::saveSession(laser_loop_closure::SaveSession::Request& request,
                                       laser_loop_closure::SaveSession::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string path = request.path.empty() ? options_.session_path : request.path;
  try {
    llc::SlamSession session = slam_->session();
    const std::size_t held = session.keyframes.size();
    if (request.prune) session = llc::pruneSession(session, system_.lifelong, nullptr);
    llc::saveSession(session, path);
    response.success = true;
    response.keyframes = std::uint32_t(session.keyframes.size());
    response.loops = std::uint32_t(session.loops.size());
    response.message = "wrote " + path + " (" + std::to_string(response.keyframes) + " keyframes" +
                       (request.prune ? " kept of " + std::to_string(held) : "") + " of " +
                       std::to_string(slam_->counters().robots_joined - slot_offset_) + " joined robots" +
                       (slot_offset_ > 0 ? " and the saved map)" : ")");
  } catch (const std::exception& e) {
    response.success = false;
    response.message = e.what();
  }
  ROS_INFO("multi_robot_backend: save_session: %s", response.message.c_str());
  return true;
}

bool MultiRobotBackendRos::saveMap(laser_loop_closure::SaveMap::Request& request, laser_loop_closure::SaveMap::Response& response) {
  const std::string stem = request.path.empty() ? options_.map_path : request.path;
  std::vector<llc::Pose2> poses;
  std::vector<std::shared_ptr<const llc::CompactScan>> scans_held;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // a snapshot; the map is built outside the lock
    poses = slam_->map().poses();
    scans_held = map_scans_;
  }
  response.success = saveMapOf(scans_held, poses, system_.map, stem, &response.message);
  ROS_INFO("multi_robot_backend: save_map: %s", response.message.c_str());
  return true;
}

void MultiRobotBackendRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const llc::MultiRobotCounters& c = slam_->counters();
  std::uint64_t total_bytes = 0;
  for (const Robot& r : robots_) {
    const double seconds = r.bytes > 0 ? (r.last_message - r.first_message).toSec() : 0.0;
    total_bytes += r.bytes;
    const std::size_t index = std::size_t(&r - robots_.data());
    status.add(r.name + " joined", slam_->joined(slot(index)));
    status.add(r.name + " joined after m", slam_->joined(slot(index)) ? slam_->joinedAtPath(slot(index)) : -1.0);  // of its own odometry path
    const auto& inbox = r.inbox->counters();
    status.add(r.name + " keyframes", inbox.taken);
    status.add(r.name + " keyframes lost", inbox.lost);
    status.add(r.name + " keyframes refused", r.keyframes_refused + inbox.refused);
    status.add(r.name + " keyframes received again", inbox.again);
    status.add(r.name + " keyframes held", r.inbox->held());
    status.add(r.name + " front end restarts", inbox.restarts);
    status.add(r.name + " loops dropped", r.loops_dropped);
    status.add(r.name + " bytes exchanged", r.bytes);
    status.add(r.name + " bytes of services", r.service_bytes);
    status.add(r.name + " bytes of loops", r.loop_bytes);
    status.add(r.name + " bytes per second", seconds > 0.0 ? double(r.bytes) / seconds : 0.0);
  }
  status.add("robots", robots_.size());
  status.add("robots joined", c.robots_joined - slot_offset_);  // the live ones (a saved map is not one)
  if (slot_offset_ > 0) status.add("saved map keyframes", slam_->robot(0).keyframes().size());
  status.add("cross-robot loops", c.cross_robot_loops);
  status.add("robot links", c.robot_links);
  status.add("bytes exchanged", total_bytes);
  status.add("cross-robot search s", c.seconds_search);
  if (!last_problem_.empty()) status.add("last problem", last_problem_);
  status.summary(diagnostic_msgs::DiagnosticStatus::OK, std::to_string(c.robots_joined - slot_offset_) + " of " +
                                                            std::to_string(robots_.size()) + " robots in the map");
}

}  // namespace llc_ros
