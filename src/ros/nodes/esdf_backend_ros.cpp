#include "laser_loop_closure/ros/nodes/esdf_backend_ros.hpp"

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "laser_loop_closure/Session.h"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/ros/io/map_publishing.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/parameters.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {
namespace {

/// Takes the keyframe's scan out (its stamp and full_circle stay): the node holds each scan once,
/// at rest (llc::mapScanAtRest with map_scan_step), after the ones `before`. `taken` (when given)
/// receives the scan as it was.
std::shared_ptr<const llc::CompactScan> withoutScan(llc::Keyframe* keyframe, double map_scan_step,
                                                    const std::vector<std::shared_ptr<const llc::CompactScan>>& before,
                                                    llc::Scan* taken = nullptr) {
  auto scan = llc::mapScanAtRest(keyframe->scan, map_scan_step, before.empty() ? nullptr : before.back().get());
  const double stamp = keyframe->scan.stamp;
  const bool full_circle = keyframe->scan.full_circle;
  if (taken) *taken = std::move(keyframe->scan);
  keyframe->scan = llc::Scan{};
  keyframe->scan.stamp = stamp;
  keyframe->scan.full_circle = full_circle;
  return scan;
}

/// The session with each keyframe's scan put back from the node's.
llc::SlamSession withScans(llc::SlamSession session, const std::vector<std::shared_ptr<const llc::CompactScan>>& scans) {
  if (scans.size() != session.keyframes.size())
    throw std::logic_error("esdf_backend: " + std::to_string(scans.size()) + " scans held for " +
                           std::to_string(session.keyframes.size()) + " keyframes");
  for (std::size_t k = 0; k < scans.size(); ++k) session.keyframes[k].scan = scans[k]->scan();
  return session;
}

}  // namespace

std::string EsdfBackendNodeOptions::validate() const {
  if (map_frame.empty() || odom_frame.empty()) return "map_frame and odom_frame must not be empty";
  if (map_frame == odom_frame) return "map_frame and odom_frame must differ";
  if (!(transform_tolerance >= 0.0)) return "transform_tolerance must not be negative";
  if (!(tf_publish_period > 0.0) || !(map_publish_period > 0.0)) return "publish periods must be positive";
  if (!(map_cpu_share > 0.0 && map_cpu_share <= 1.0)) return "map_cpu_share must be in (0, 1]";
  if (session_part_keyframes < 1) return "session_part_keyframes must be at least 1";
  if (!(cloud_voxel_size >= 0.0)) return "cloud_voxel_size must not be negative";
  if (const std::string bad = llc::checkMapScanStep(map_scan_step); !bad.empty()) return "map_scan_step " + bad;
  if (max_pending_loops < 0 || queue_size < 1) return "max_pending_loops >= 0 and queue_size >= 1";
  if (session_path.empty()) return "session_path must not be empty";
  return "";
}

EsdfBackendRos::EsdfBackendRos(ros::NodeHandle nh, ros::NodeHandle private_nh) : diagnostics_(nh, private_nh) {
  loadNodeParameters(
      private_nh, "esdf_backend", &options_,
      [](EsdfBackendNodeOptions& o, ParameterReader& r) { visitEsdfBackendParameters(o, r); }, &system_);
  options_.map_frame = tfFrame(options_.map_frame);  // tf2 refuses tf1's leading slash
  options_.odom_frame = tfFrame(options_.odom_frame);
  back_ = std::make_unique<llc::SlamBackEnd>(system_.slam.esdf, system_.slam.gate_loops, system_.slam.consensus);

  path_pub_ = nh.advertise<nav_msgs::Path>("path", 2);
  pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  map_updates_ = std::make_unique<MapUpdatePublisher>(nh, system_.map, options_.latch_map);
  cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
  marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("graph_markers", 1, true);
  record_pub_ = private_nh.advertise<laser_loop_closure::LoopClosure>("loop_records", 1000);
  keyframe_sub_ = nh.subscribe("keyframes", options_.queue_size, &EsdfBackendRos::onKeyframe, this);
  packed_keyframe_sub_ = nh.subscribe("packed_keyframes", options_.queue_size, &EsdfBackendRos::onPackedKeyframe, this);
  loop_sub_ = nh.subscribe("loop_closures", options_.queue_size, &EsdfBackendRos::onLoop, this);
  // Not latched: a session comes in parts (a latch would keep only the last); the queue holds
  // every part of a long one for a subscriber over TCP.
  session_pub_ = nh.advertise<laser_loop_closure::Session>("session", 1000, false);
  ros::NodeHandle service_nh = service_thread_.handle(private_nh);
  save_map_srv_ = service_nh.advertiseService("save_map", &EsdfBackendRos::saveMap, this);
  save_session_srv_ = service_nh.advertiseService("save_session", &EsdfBackendRos::saveSession, this);
  load_session_srv_ = service_nh.advertiseService("load_session", &EsdfBackendRos::loadSession, this);
  service_thread_.start();
  place_check_srv_ = place_thread_.handle(private_nh).advertiseService("place_check", &EsdfBackendRos::placeCheck, this);
  nearby_srv_ = place_thread_.handle(private_nh).advertiseService("nearby_keyframes", &EsdfBackendRos::nearbyKeyframes, this);
  place_thread_.start();
  if (options_.publish_tf) {
    tf_timer_ = transform_thread_.handle(nh).createTimer(ros::Duration(options_.tf_publish_period),
                                                         [this](const ros::TimerEvent&) { publishTransform(); });
    transform_thread_.start();
  }
  // The map is updated on its own thread: on the nodelet's queue a rebuild of a 10 km map (3 s)
  // held every keyframe behind it, and the front end's place checks timed out meanwhile.
  // Ticks often: keyframes left waiting to be drawn (max_draws_per_update) go at the next tick
  // that map_cpu_share allows; the rest of the map every map_publish_period.
  map_timer_ = map_thread_.handle(nh).createWallTimer(ros::WallDuration(std::min(options_.map_publish_period, 0.1)),
                                                      [this](const ros::WallTimerEvent&) { publishMap(); });
  map_thread_.start();
  diagnostics_.setHardwareID("none");
  diagnostics_.add("esdf backend", this, &EsdfBackendRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_.force_update(); });
}

EsdfBackendRos::~EsdfBackendRos() {
  // The transform, service, place-check and map threads read members: stopped before any of them goes.
  transform_thread_.stop();
  service_thread_.stop();
  place_thread_.stop();
  map_thread_.stop();
  tf_timer_.stop();
  map_timer_.stop();
  diagnostics_timer_.stop();
}

std_msgs::Header EsdfBackendRos::mapHeader() const {
  std_msgs::Header header;
  header.frame_id = options_.map_frame;
  header.stamp = back_->keyframes().empty() ? ros::Time::now() : ros::Time().fromSec(back_->keyframes().back().stamp);
  return header;
}

void EsdfBackendRos::onKeyframe(const laser_loop_closure::Keyframe::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  held_keyframes_.push_back(msg);
  takeHeldKeyframes();
}

void EsdfBackendRos::onPackedKeyframe(const laser_loop_closure::PackedKeyframe::ConstPtr& packed) {
  auto msg = boost::make_shared<laser_loop_closure::Keyframe>();
  std::string error;
  if (unpackKeyframeMsg(*packed, msg.get(), &error)) return onKeyframe(msg);
  std::lock_guard<std::mutex> lock(mutex_);
  ++refused_keyframes_;
  last_problem_ = "keyframe " + std::to_string(packed->index) + ": " + error;
  ROS_WARN_THROTTLE(5.0, "esdf_backend: keyframe refused: %s", last_problem_.c_str());
}

void EsdfBackendRos::takeHeldKeyframes() {
  // Keyframes and loops come on two topics, whose order ROS does not keep; llc slam applies
  // the loops of keyframe k before it adds keyframe k + 1, and so does this.
  while (!held_keyframes_.empty()) {
    const laser_loop_closure::Keyframe::ConstPtr next = held_keyframes_.front();
    if (next->loops_before > loops_taken_) {
      if (held_keyframes_.size() <= kMostHeldKeyframes) break;
      ++loop_order_resyncs_;
      ROS_WARN_THROTTLE(5.0, "esdf_backend: keyframe %u waited for %llu loop messages that did not come: taken anyway",
                        next->index, static_cast<unsigned long long>(next->loops_before - loops_taken_));
      loops_taken_ = next->loops_before;
    }
    held_keyframes_.pop_front();
    takeKeyframe(*next);
  }
  state_changed_.notify_all();
}

void EsdfBackendRos::takeKeyframe(const laser_loop_closure::Keyframe& msg) {
  const std::size_t expected = back_->keyframes().size();
  std::string error;
  llc::Keyframe keyframe;
  llc::Pose2 motion;
  Eigen::Matrix3d covariance;
  if (msg.index != expected) {
    error = "keyframe " + std::to_string(msg.index) + " arrived, " + std::to_string(expected) + " expected";
  } else if (fromKeyframeMsg(msg, &keyframe, &motion, &covariance, &error)) {
    // The scan is held once, here, for the map and sessions: the pose graph needs none.
    std::shared_ptr<const llc::CompactScan> scan = withoutScan(&keyframe, options_.map_scan_step, map_scans_);
    // Kept whatever its odometry: a note says what was unusable and replaced.
    const std::string note = back_->addKeyframe(std::move(keyframe), motion, covariance);
    if (!note.empty()) {
      last_problem_ = "keyframe " + std::to_string(msg.index) + ": " + note;
      ROS_WARN_THROTTLE(5.0, "esdf_backend: %s", last_problem_.c_str());
    }
    features_.emplace_back(msg.features.begin(), msg.features.end());
    map_scans_.push_back(std::move(scan));
  }
  if (!error.empty()) {
    ++refused_keyframes_;
    ++refused_in_a_row_;
    last_problem_ = error;
    ROS_WARN_THROTTLE(5.0, "esdf_backend: keyframe refused: %s", error.c_str());
    return;
  }
  refused_in_a_row_ = 0;
  // Loops that waited for this keyframe.
  const std::size_t size = back_->keyframes().size();
  for (auto it = pending_loops_.begin(); it != pending_loops_.end();) {
    if (it->from_keyframe < size && it->to_keyframe < size) {
      applyLoop(*it);
      it = pending_loops_.erase(it);
    } else {
      ++it;
    }
  }
  map_dirty_ = true;
  publishPoses();
}

void EsdfBackendRos::onLoop(const laser_loop_closure::LoopClosure::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  ++loops_taken_;
  takeLoop(msg);
  takeHeldKeyframes();  // one may have waited for this loop
}

void EsdfBackendRos::takeLoop(const laser_loop_closure::LoopClosure::ConstPtr& msg) {
  if (!msg->accepted) {
    llc::LoopRecord record;
    record.loop = fromLoopClosureMsg(*msg);
    record.refusal = record.loop.refusal;
    record.reject_reason = msg->reject_reason;
    refused_by_alignment_.push_back(record);
    return;
  }
  const std::size_t size = back_->keyframes().size();
  if (msg->from_keyframe < size && msg->to_keyframe < size) {
    applyLoop(*msg);
    publishPoses();
    return;
  }
  if (pending_loops_.size() >= std::size_t(options_.max_pending_loops)) {
    ++dropped_loops_;
    last_problem_ = "a loop waited for keyframes that never came";
    ROS_WARN_THROTTLE(5.0, "esdf_backend: too many loops wait for their keyframes; the oldest is dropped");
    pending_loops_.pop_front();
  }
  pending_loops_.push_back(*msg);
}

template <class Response, class Answer>
void EsdfBackendRos::answerFromFrontEndState(std::size_t keyframes, std::uint64_t loops, std::size_t& asked,
                                             std::size_t& unanswered, Response& response, Answer&& answer) {
  std::unique_lock<std::mutex> lock(mutex_);
  ++asked;
  // Wall time: the front end waits on this answer, and the clock may stand still.
  const bool reached = state_changed_.wait_for(lock, std::chrono::seconds(2), [&] {
    return back_->keyframes().size() >= keyframes && loops_taken_ >= loops;
  });
  if (!reached) {
    ++unanswered;
    response.message = "the back end holds " + std::to_string(back_->keyframes().size()) + " keyframes and " +
                       std::to_string(loops_taken_) + " loop messages, not " + std::to_string(keyframes) + " and " +
                       std::to_string(loops) + ", after 2 s";
    return;
  }
  try {
    answer();
    response.answered = true;
  } catch (const std::exception& e) {
    ++unanswered;
    response.message = e.what();
  }
}

bool EsdfBackendRos::placeCheck(laser_loop_closure::PlaceCheck::Request& request,
                                laser_loop_closure::PlaceCheck::Response& response) {
  answerFromFrontEndState(request.keyframes, request.loops, place_checks_, place_checks_unanswered_, response, [&] {
    response.chi2 = back_->placeChi2(request.from_keyframe, request.to_keyframe, request.radius);
  });
  return true;
}

bool EsdfBackendRos::nearbyKeyframes(laser_loop_closure::NearbyKeyframes::Request& request,
                                     laser_loop_closure::NearbyKeyframes::Response& response) {
  answerFromFrontEndState(request.keyframes, request.loops, nearby_asked_, nearby_unanswered_, response, [&] {
    for (const llc::NearbyKeyframe& near : back_->nearbyKeyframes(request.keyframe, request.before, request.max_distance,
                                                                  request.max_std, request.count)) {
      response.nearby.push_back(std::uint32_t(near.keyframe));
      response.poses.push_back(toPose2D(near.pose));
    }
  });
  return true;
}

void EsdfBackendRos::applyLoop(const laser_loop_closure::LoopClosure& msg) {
  const llc::LoopRecord record = back_->addLoop(fromLoopClosureMsg(msg));
  if (!record.applied) {
    ++refusals_[std::size_t(record.refusal)];
    ROS_DEBUG("esdf_backend: loop %u -> %u refused: %s", msg.from_keyframe, msg.to_keyframe, record.reject_reason.c_str());
  }
  record_pub_.publish(toLoopClosureMsg(record, msg.header));
  // Loops refused earlier that this one completed a consensus with: applied now, said again.
  const std::vector<std::size_t>& agreed = back_->lastConsensus();
  for (std::size_t i = 0; i + 1 < agreed.size(); ++i) {  // (the last is this one, published above)
    --refusals_[std::size_t(llc::LoopRefusal::kBackEndGate)];  // only the gate's refusals wait for a consensus
    const llc::LoopRecord& earlier = back_->loops()[agreed[i]];
    const double stamp = back_->keyframes()[earlier.loop.to].stamp;  // a loop is stamped with its newer keyframe
    std_msgs::Header header = msg.header;
    if (stamp > 0.0) header.stamp = ros::Time(stamp);
    record_pub_.publish(toLoopClosureMsg(earlier, header));
  }
  if (!agreed.empty()) ROS_INFO("esdf_backend: %zu loops the gate had refused applied together (they agree)", agreed.size());
  map_dirty_ = true;
}

void EsdfBackendRos::publishPoses() {
  {
    std::lock_guard<std::mutex> lock(transform_mutex_);
    has_map_to_odom_ = !back_->keyframes().empty() && back_->keyframes().back().has_wheel_odometry;
    if (has_map_to_odom_) map_to_odom_ = back_->mapToOdom();
  }
  if (back_->keyframes().empty()) return;
  const std_msgs::Header header = mapHeader();
  path_pub_.publish(toPathMsg(back_->keyframes(), back_->poses(), header));
  geometry_msgs::PoseWithCovarianceStamped pose;
  pose.header = header;
  pose.pose.pose = toPoseMsg(back_->poses().back());
  const Eigen::Matrix3d c = back_->latestCovariance();
  const int index[3] = {0, 1, 5};  // x, y, yaw in the 6x6 (x, y, z, roll, pitch, yaw)
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) pose.pose.covariance[std::size_t(6 * index[r] + index[col])] = c(r, col);
  pose_pub_.publish(pose);
}

void EsdfBackendRos::publishMap() {
  // A snapshot under the lock (poses, loops and shared scans: cheap), the update outside it:
  // keyframes, loops and place checks go on meanwhile.
  std::lock_guard<std::mutex> building(map_building_);
  // Throttled by its own cost (map_cpu_share): a large map is updated less often; it stays dirty.
  const auto now = std::chrono::steady_clock::now();
  if (now < next_map_allowed_) return;
  std::vector<llc::Pose2> poses;
  std::vector<std::shared_ptr<const llc::CompactScan>> scans_held;
  std::vector<llc::LoopRecord> loops;
  std_msgs::Header header;
  bool graph_changed = false;  // else only keyframes left waiting to be drawn, or a new subscriber
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool due = now >= last_map_update_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                   std::chrono::duration<double>(options_.map_publish_period));
    graph_changed = map_dirty_ && due;
    if (!(graph_changed || map_keyframes_waiting_ > 0 || map_updates_->wholeDue()) || back_->keyframes().empty()) return;
    if (graph_changed) map_dirty_ = false, last_map_update_ = now;
    header = mapHeader();
    poses = back_->poses();
    scans_held = map_scans_;
    loops = refused_by_alignment_;
    loops.insert(loops.end(), back_->loops().begin(), back_->loops().end());
  }
  const auto start = std::chrono::steady_clock::now();
  std::string problem;
  MapUpdatePublisher::Published published;
  try {
    published = map_updates_->publish(scans_held, poses, header);
  } catch (const std::exception& e) {
    problem = std::string("map: ") + e.what();
    ROS_WARN_THROTTLE(30.0, "esdf_backend: map not updated: %s", e.what());
  }
  if (published.update.too_large > 0)
    ROS_WARN_THROTTLE(30.0, "esdf_backend: %zu keyframes not drawn on /map: it would exceed map/max_cells",
                      published.update.too_large);
  const double map_seconds = llc::secondsSince(start);
  if (graph_changed) marker_pub_.publish(graphMarkers(poses, loops, header));
  // The cloud of every return costs as much as the grid: built only for someone listening.
  if (graph_changed && cloud_pub_.getNumSubscribers() > 0) {
    std::vector<llc::Scan> expanded;
    expanded.reserve(scans_held.size());
    for (const auto& scan : scans_held) expanded.push_back(scan->scan());
    std::vector<const llc::Scan*> scans;
    for (const llc::Scan& scan : expanded) scans.push_back(&scan);
    cloud_pub_.publish(toCloudMsg(scans, poses, system_.map.max_range, options_.cloud_voxel_size, header));
  }
  const double took = llc::secondsSince(start);
  next_map_allowed_ = std::chrono::steady_clock::now() +
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double>(took / options_.map_cpu_share - took));
  std::lock_guard<std::mutex> lock(mutex_);
  last_map_seconds_ = map_seconds;
  last_map_whole_ = published.whole;
  whole_maps_sent_ += published.whole;
  double& longest = published.whole ? longest_whole_map_seconds_ : longest_map_parts_seconds_;
  longest = std::max(longest, map_seconds);
  map_keyframes_waiting_ = published.update.waiting;
  map_bytes_ = map_updates_->bytes();
  if (!problem.empty()) last_problem_ = problem;
}

void EsdfBackendRos::publishTransform() {
  llc::Pose2 map_to_odom;
  {
    std::lock_guard<std::mutex> lock(transform_mutex_);
    if (!has_map_to_odom_) return;
    map_to_odom = map_to_odom_;
  }
  const ros::Time now = ros::Time::now();
  // Simulated time has not started, or has not moved since the last broadcast (tf would
  // warn about a repeated stamp).
  if (now.isZero() || now == last_tf_time_) return;
  last_tf_time_ = now;
  geometry_msgs::TransformStamped t;
  t.header.frame_id = options_.map_frame;
  t.child_frame_id = options_.odom_frame;
  t.header.stamp = now + ros::Duration(options_.transform_tolerance);
  t.transform = toTransformMsg(map_to_odom);
  tf_broadcaster_.sendTransform(t);
}

bool EsdfBackendRos::saveMap(laser_loop_closure::SaveMap::Request& request, laser_loop_closure::SaveMap::Response& response) {
  const std::string stem = request.path.empty() ? options_.map_path : request.path;
  std::vector<llc::Pose2> poses;
  std::vector<std::shared_ptr<const llc::CompactScan>> scans_held;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // a snapshot; the map is built outside the lock
    poses = back_->poses();
    scans_held = map_scans_;
  }
  response.success = saveMapOf(scans_held, poses, system_.map, stem, &response.message);
  ROS_INFO("esdf_backend: save_map: %s", response.message.c_str());
  return true;
}

bool EsdfBackendRos::saveSession(laser_loop_closure::SaveSession::Request& request,
                                 laser_loop_closure::SaveSession::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string path = request.path.empty() ? options_.session_path : request.path;
  try {
    std::vector<std::vector<double>> features;
    features.reserve(features_.size());
    for (const std::vector<float>& f : features_) features.emplace_back(f.begin(), f.end());
    llc::SlamSession session = withScans(llc::sessionOf(*back_, features, &robots_), map_scans_);
    const std::size_t held = session.keyframes.size();
    if (request.prune) session = llc::pruneSession(session, system_.lifelong, nullptr);
    llc::saveSession(session, path);
    response.success = true;
    response.keyframes = std::uint32_t(session.keyframes.size());
    response.loops = std::uint32_t(session.loops.size());
    response.message = "wrote " + path + " (" + std::to_string(response.keyframes) + " keyframes" +
                       (request.prune ? " kept of " + std::to_string(held) : "") + ", " + std::to_string(response.loops) + " loops)";
  } catch (const std::exception& e) {
    response.success = false;
    response.message = e.what();
  }
  ROS_INFO("esdf_backend: save_session: %s", response.message.c_str());
  return true;
}

bool EsdfBackendRos::loadSession(laser_loop_closure::LoadSession::Request& request,
                                 laser_loop_closure::LoadSession::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string path = request.path.empty() ? options_.session_path : request.path;
  llc::SlamSession session;
  try {
    session = llc::loadSession(path);
  } catch (const llc::SessionError& e) {
    response.message = e.what();
  }
  // The scans are held at rest here (the back end restores none); the front end gets them as the
  // file has them.
  std::vector<std::shared_ptr<const llc::CompactScan>> scans;
  std::vector<llc::Scan> file_scans;
  file_scans.resize(session.keyframes.size());
  for (std::size_t k = 0; k < session.keyframes.size(); ++k)
    scans.push_back(withoutScan(&session.keyframes[k], options_.map_scan_step, scans, &file_scans[k]));
  if (response.message.empty()) {
    const std::string error = back_->restore(session);
    if (!error.empty()) response.message = path + ": not restored: " + error;
  }
  if (!response.message.empty()) {
    response.success = false;
    ROS_WARN("esdf_backend: load_session: %s", response.message.c_str());
    return true;
  }
  features_.clear();
  for (const std::vector<double>& f : session.features) features_.emplace_back(f.begin(), f.end());
  robots_ = llc::KeyframeRobots::afterRestore(session, request.continue_odometry);
  map_scans_ = std::move(scans);
  pending_loops_.clear();
  refused_by_alignment_.clear();
  refused_keyframes_ = 0;
  refused_in_a_row_ = 0;
  map_dirty_ = true;
  // The front end restores its keyframes from these parts, in order (one message of a long
  // session would be tens of MB).
  ++session_loads_;
  const std::size_t n = session.keyframes.size(), per_part = std::size_t(options_.session_part_keyframes);
  const std::size_t parts = std::max<std::size_t>(1, (n + per_part - 1) / per_part);
  for (std::size_t part = 0; part < parts; ++part) {
    laser_loop_closure::Session msg;
    msg.header.stamp = ros::Time::now();
    msg.load = session_loads_;
    msg.part = std::uint32_t(part);
    msg.parts = std::uint32_t(parts);
    msg.first_keyframe = std::uint32_t(part * per_part);
    msg.total_keyframes = std::uint32_t(n);
    msg.path = path;
    msg.continue_odometry = request.continue_odometry;
    for (std::size_t k = part * per_part; k < std::min(n, (part + 1) * per_part); ++k) {
      llc::Keyframe keyframe = session.keyframes[k];
      keyframe.scan = std::move(file_scans[k]);
      msg.keyframes.push_back(toKeyframeMsg(keyframe, k, llc::OdometryStep{}, ""));
      msg.keyframes.back().features = session.features[k];
    }
    session_pub_.publish(msg);
  }
  publishPoses();
  response.success = true;
  response.keyframes = std::uint32_t(session.keyframes.size());
  response.loops = std::uint32_t(session.loops.size());
  response.message = "restored " + std::to_string(response.keyframes) + " keyframes and " +
                     std::to_string(response.loops) + " loops from " + path;
  ROS_INFO("esdf_backend: load_session: %s", response.message.c_str());
  return true;
}

void EsdfBackendRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  const llc::BackEndCounters& c = back_->counters();
  if (c.keyframes == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no keyframe yet");
  else if (refused_in_a_row_ > 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "keyframes refused, the graph stopped: " + last_problem_);
  else if (refused_keyframes_ > 0)  // e.g. while the front end took in a loaded session: mapping went on
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                   std::to_string(refused_keyframes_) + " keyframes refused, mapping goes on; the last: " + last_problem_);
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "mapping");
  status.add("keyframes", c.keyframes);
  status.add("refused keyframes", refused_keyframes_);
  status.add("keyframes refused since the last one taken", refused_in_a_row_);
  status.add("keyframes loosely linked (odometry unusable)", c.loosely_linked_keyframes);
  status.add("loops applied", c.loops_accepted);
  status.add("loops refused by the gate", c.refused_by_gate);
  status.add("loops applied by consensus (refused by the gate, then agreed with others)", c.applied_by_consensus);
  status.add("malformed loops", c.refused_loops);
  status.add("candidates refused by alignment", refused_by_alignment_.size());
  status.add("place checks answered for the front end", place_checks_ - place_checks_unanswered_);
  status.add("place checks unanswered", place_checks_unanswered_);
  status.add("nearby keyframes asked by the front end", nearby_asked_);
  status.add("nearby keyframes unanswered", nearby_unanswered_);
  status.add("keyframes held for their loops", held_keyframes_.size());
  status.add("keyframes taken without all their loops (loop messages lost)", loop_order_resyncs_);
  status.add("loops waiting for keyframes", pending_loops_.size());
  status.add("loops dropped", dropped_loops_);
  status.add("seconds in the filter", c.seconds);
  status.add("seconds of the last map update", last_map_seconds_);
  status.add("the last map update was whole", last_map_whole_);
  status.add("seconds of the longest map update by parts", longest_map_parts_seconds_);
  status.add("seconds of the longest whole map", longest_whole_map_seconds_);
  status.add("whole maps sent", whole_maps_sent_);
  status.add("keyframes waiting to be drawn on the map", map_keyframes_waiting_);
  status.add("bytes of the map's grid", map_bytes_);
  std::size_t scan_bytes = 0, feature_bytes = 0;
  for (const auto& scan : map_scans_) scan_bytes += scan->bytes();
  for (const auto& features : features_) feature_bytes += sizeof(features) + features.capacity() * sizeof(float);
  status.add("bytes of the keyframes' scans", scan_bytes);
  status.add("bytes of the keyframes' features (kept for sessions)", feature_bytes);
  status.add("bytes of the pose graph (ESDF, about)", back_->esdf() ? back_->esdf()->bytes() : 0);
  // Loops the back end refused, by why (llc::LoopRefusal's names).
  for (llc::LoopRefusal kind : {llc::LoopRefusal::kBackEndGate, llc::LoopRefusal::kBackEndUnsolvable,
                                llc::LoopRefusal::kBackEndMalformed})
    status.add(std::string("loops refused: ") + llc::loopRefusalName(kind), refusals_[std::size_t(kind)]);
  status.add("sessions restored (~load_session)", session_loads_);
  callback_timing_.addTo(status, "keyframe and loop callbacks");
  status.add("last problem", last_problem_);
}

}  // namespace llc_ros
