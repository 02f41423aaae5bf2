#include "laser_loop_closure/ros/nodes/localization_ros.hpp"

#include <ros/package.h>

#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/ros/io/map_publishing.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/parameters.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

std::string LocalizationNodeOptions::validate() const {
  const std::string input_error = input.validate();
  if (!input_error.empty()) return input_error;
  if (map_frame.empty()) return "map_frame must not be empty";
  if (tfFrame(map_frame) == tfFrame(input.odom_frame)) return "map_frame and odom_frame must differ";
  if (!(transform_tolerance >= 0.0)) return "transform_tolerance must not be negative";
  if (!(tf_publish_period > 0.0)) return "tf_publish_period must be > 0 s";
  if (!(hint_min_radius > 0.0) || !std::isfinite(hint_min_radius)) return "hint_min_radius must be > 0 m";
  return "";
}

namespace {

/// Where x, y and yaw sit in a ROS 6x6 covariance (x, y, z, roll, pitch, yaw), row-major.
constexpr int kPlanar[3] = {0, 1, 5};

}  // namespace

LocalizationRos::LocalizationRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : tf_listener_(tf_buffer_, nh), diagnostics_(nh, private_nh) {
  loadNodeParameters(
      private_nh, "localization", &options_,
      [](LocalizationNodeOptions& o, ParameterReader& r) { visitLocalizationParameters(o, r); }, &system_);
  options_.input.odom_frame = tfFrame(options_.input.odom_frame);
  options_.map_frame = tfFrame(options_.map_frame);
  if (options_.map_session.empty())
    throw std::runtime_error("localization: map_session is not set: give the session to localise on (llc slam "
                             "--save-session, or esdf_backend's ~save_session)");
  if (options_.model_path.empty())
    options_.model_path = ros::package::getPath("laser_loop_closure") + "/config/classifier.yaml";
  llc::ClassifierModel model;
  llc::SlamSession session;
  try {
    model = llc::loadClassifierModel(options_.model_path);
    session = llc::loadSession(options_.map_session);
    localizer_ = std::make_unique<llc::Localizer>(model, system_.slam, session, system_.localization);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("localization: ") + e.what());
  }
  ROS_INFO("localization: map %s (%zu keyframes), model %s; searching with no initial pose",
           options_.map_session.c_str(), session.keyframes.size(), options_.model_path.c_str());

  // The saved map, once and latched: it never changes in this mode.
  map_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  {
    std::vector<const llc::Scan*> scans;
    for (const llc::Keyframe& k : session.keyframes) scans.push_back(&k.scan);
    std_msgs::Header header;
    header.frame_id = options_.map_frame;
    header.stamp = ros::Time::now();
    try {
      map_pub_.publish(toOccupancyGridMsg(llc::buildOccupancyGrid(scans, session.poses, system_.map), header));
    } catch (const std::exception& e) {
      ROS_WARN("localization: the session's map was not published: %s", e.what());
    }
  }
  pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  status_pub_ = private_nh.advertise<laser_loop_closure::LocalizationStatus>("status", 1, true);
  state_.status.header.frame_id = options_.map_frame;
  state_.status.state = llc::localizationStateName(llc::LocalizationState::kLost);
  state_.status.fit = -1.0;
  state_.status.why = "no fix yet";
  status_pub_.publish(state_.status);
  last_published_state_ = state_.status.state;

  wheels_ = makeWheelOdometryReader(tf_buffer_, options_.input, system_.slam);
  backlog_ = std::make_unique<llc::ScanBacklog<PendingScan>>(scanBacklogOptions(options_.input));
  publishState();
  worker_ = std::thread([this] { work(); });
  receiver_ = std::make_unique<ScanReceiver>("localization", options_.input, tf_buffer_, nh, *wheels_, *backlog_);

  ros::NodeHandle service_nh = service_thread_.handle(private_nh);
  relocalize_srv_ = service_nh.advertiseService("relocalize", &LocalizationRos::relocalize, this);
  initial_pose_sub_ = service_thread_.handle(nh).subscribe("initialpose", 10, &LocalizationRos::onInitialPose, this);
  service_thread_.start();
  if (options_.publish_tf) {
    tf_timer_ = transform_thread_.handle(nh).createTimer(ros::Duration(options_.tf_publish_period),
                                                         [this](const ros::TimerEvent&) { publishTransform(); });
    transform_thread_.start();
  }
  diagnostics_.setHardwareID("none");
  diagnostics_.add("localization", this, &LocalizationRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) {
    receiver_->releaseHeldScans();
    diagnostics_.force_update();
  });
}

LocalizationRos::~LocalizationRos() {
  service_thread_.stop();
  transform_thread_.stop();
  diagnostics_timer_.stop();
  backlog_->stop();
  if (worker_.joinable()) worker_.join();
  receiver_.reset();
}

void LocalizationRos::work() {
  PendingScan pending;
  std::size_t drops_reported = 0;
  while (backlog_->pop(&pending)) {  // runs the tasks posted meanwhile first
    warnOfScansDroppedBehind("localization", backlog_->counters(), options_.input.max_lag, &drops_reported);
    processScan(pending);
    scan_latency_.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - pending.arrival).count());
    pending = PendingScan{};
    publishState();
  }
}

void LocalizationRos::publishState() {
  state_.counters = localizer_->counters();
  std::lock_guard<std::mutex> lock(state_mutex_);
  published_ = state_;
}

void LocalizationRos::processScan(const PendingScan& pending) {
  const laser_loop_closure::Scan360& msg = *pending.msg;
  std::string error;
  llc::Scan scan;
  llc::Pose2 wheel_odometry;
  if (!takeScan("localization", pending, *wheels_, &scan, &wheel_odometry, &error)) {
    ++state_.malformed;
    state_.last_problem = error;
    ROS_WARN_THROTTLE(5.0, "localization: scan skipped: %s", error.c_str());
    return;
  }
  const llc::LocalizationStep step = localizer_->addScan(scan, pending.has_wheel_odometry ? &wheel_odometry : nullptr);
  if (!step.skip_reason.empty()) {
    state_.last_problem = step.skip_reason;
    ROS_WARN_THROTTLE(5.0, "localization: scan skipped: %s", step.skip_reason.c_str());
    return;
  }
  const bool laser_odometry = !pending.has_wheel_odometry;
  if (laser_odometry) publishOdometry(step, msg.header);
  if (step.searched) state_.last_search_seconds = step.seconds;
  if (step.has_pose) {
    // map -> odom: the scan's pose in the map over its pose in odom_frame (the wheels', or
    // without them the localizer's own chain, which is what odom -> base is broadcast from).
    const llc::Pose2 odometry = laser_odometry ? step.trajectory_pose : wheel_odometry;
    state_.has_map_to_odom = true;
    state_.map_to_odom = llc::compose(step.pose, llc::inverse(odometry));
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header.stamp = msg.header.stamp;
    pose.header.frame_id = options_.map_frame;
    pose.pose.pose = toPoseMsg(step.pose);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) pose.pose.covariance[std::size_t(6 * kPlanar[r] + kPlanar[c])] = step.covariance(r, c);
    pose_pub_.publish(pose);
  }
  updateStatus(step, msg.header);
}

void LocalizationRos::updateStatus(const llc::LocalizationStep& step, const std_msgs::Header& scan_header) {
  laser_loop_closure::LocalizationStatus& status = state_.status;
  const std::string state = llc::localizationStateName(step.state);
  if (step.fixed) {
    ROS_INFO("localization: localized at (%.2f, %.2f, %.1f deg) in %s after %.1f m of path%s", step.pose.x, step.pose.y,
             step.pose.theta * 180.0 / M_PI, options_.map_frame.c_str(), localizer_->pathLength(),
             localizer_->counters().relocalizations > 0 ? " (relocalised)" : "");
    status.why.clear();
  }
  if (step.lost) {
    ROS_WARN("localization: lost: %s; searching the whole map again", step.why_lost.c_str());
    status.why = step.why_lost;
  }
  if (step.state == llc::LocalizationState::kLost && status.why.empty()) status.why = "searching";
  if (step.keyframe) status.fit = step.fit;
  if (!step.keyframe && state == last_published_state_) return;
  status.header.stamp = scan_header.stamp;
  status.state = state;
  sendStatus();
}

void LocalizationRos::sendStatus() {
  laser_loop_closure::LocalizationStatus& status = state_.status;
  status.hinted = localizer_->hinted();
  const llc::LocalizerCounters& c = localizer_->counters();
  status.keyframes = std::uint32_t(c.keyframes);
  status.fixes = std::uint32_t(c.fixes);
  status.lost_events = std::uint32_t(c.lost_events);
  status.relocalizations = std::uint32_t(c.relocalizations);
  status.path_length = localizer_->pathLength();
  status_pub_.publish(status);
  last_published_state_ = status.state;
}

void LocalizationRos::searchAgain(const std::string& why) {
  state_.status.state = llc::localizationStateName(localizer_->state());
  state_.status.why = why;
  sendStatus();
  publishState();
}

void LocalizationRos::publishOdometry(const llc::LocalizationStep& step, const std_msgs::Header& scan_header) {
  if (!step.has_trajectory_pose || scan_header.stamp <= last_odometry_stamp_) return;  // tf warns on older stamps
  last_odometry_stamp_ = scan_header.stamp;
  geometry_msgs::TransformStamped t;
  t.header.stamp = scan_header.stamp;
  t.header.frame_id = options_.input.odom_frame;
  t.child_frame_id = tfFrame(scan_header.frame_id);
  t.transform = toTransformMsg(step.trajectory_pose);
  odometry_broadcaster_.sendTransform(t);
}

void LocalizationRos::publishTransform() {
  llc::Pose2 map_to_odom;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    if (!published_.has_map_to_odom) return;
    map_to_odom = published_.map_to_odom;
  }
  const ros::Time now = ros::Time::now();
  if (now.isZero() || now == last_tf_time_) return;  // simulated time not started, or standing still
  last_tf_time_ = now;
  geometry_msgs::TransformStamped t;
  t.header.frame_id = options_.map_frame;
  t.child_frame_id = options_.input.odom_frame;
  t.header.stamp = now + ros::Duration(options_.transform_tolerance);
  t.transform = toTransformMsg(map_to_odom);
  tf_broadcaster_.sendTransform(t);
}

void LocalizationRos::onInitialPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg) {
  const std::string frame = tfFrame(msg->header.frame_id);
  if (!frame.empty() && frame != options_.map_frame) {
    ROS_WARN("localization: pose hint ignored: it is in '%s', not in the map frame '%s'", frame.c_str(),
             options_.map_frame.c_str());
    return;
  }
  const llc::Pose2 pose = toPose2(msg->pose.pose);
  const double sigma = std::sqrt(std::max(msg->pose.covariance[0], msg->pose.covariance[7]));
  const double radius = std::isfinite(sigma) ? std::max(options_.hint_min_radius, 3.0 * sigma) : options_.hint_min_radius;
  backlog_->post([this, pose, radius] {
    if (!localizer_->hint(pose, radius)) {
      ROS_WARN("localization: pose hint ignored: not a finite pose");
      return;
    }
    ROS_INFO("localization: pose hint (%.2f, %.2f, %.1f deg): searching the map within %.1f m of it", pose.x, pose.y,
             pose.theta * 180.0 / M_PI, radius);
    searchAgain("a pose hint was given: searching near it");
  });
}

bool LocalizationRos::relocalize(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  backlog_->post([this] {
    localizer_->relocalize("asked by ~relocalize");
    ROS_INFO("localization: ~relocalize: searching the whole map from the next keyframe");
    searchAgain("asked by ~relocalize: searching the whole map");
  });
  response.success = true;
  response.message = "searching the whole map from the next keyframe";
  return true;
}

void LocalizationRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  WorkerState w;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    w = published_;
  }
  const std::size_t received = receiver_->received();
  const llc::ScanBacklogCounters backlog = backlog_->counters();
  const std::string problem = w.last_problem.empty() ? receiver_->lastProblem() : w.last_problem;
  char fit[32];
  std::snprintf(fit, sizeof fit, "%.2f", w.status.fit);
  if (received == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no scan received yet");
  else if (w.status.state != llc::localizationStateName(llc::LocalizationState::kLocalized))
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "lost, searching the map: " + w.status.why);
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, std::string("localized, fit ") + fit);
  receiver_->addTo(status);
  status.add("state", w.status.state);
  status.add("fit of the newest keyframe", fit);
  status.add("why", w.status.why);
  status.add("pose hint narrowing the search", w.status.hinted ? "yes" : "no");
  const llc::LocalizerCounters& c = w.counters;
  status.add("keyframes", c.keyframes);
  status.add("keyframes searched against the whole map", c.searched_keyframes);
  status.add("loops to the map they gave", c.loops_to_map);
  status.add("fixes", c.fixes);
  status.add("lost events", c.lost_events);
  status.add("relocalisations", c.relocalizations);
  status.add("fixes refused (recent keyframes did not fit)", c.fixes_refused);
  status.add("fixes dropped on probation", c.fixes_dropped);
  status.add("tracked keyframes", c.tracked_keyframes);
  status.add("keyframes not fitting the map", c.misfit_keyframes);
  status.add("keyframes off the map", c.off_map_keyframes);
  status.add("keyframes fitting where the odometry rules out (max_track_chi2)", c.disagreeing_keyframes);
  status.add("own keyframes whose scans were let go (memory)", c.scans_released);
  status.add("newest search (s)", w.last_search_seconds);
  status.add("path driven (m)", w.status.path_length);
  addBacklogTo(backlog, status);
  scan_latency_.addTo(status, "scan arrival to processed");
  status.add("malformed scans", w.malformed);
  status.add("tf stamps that jumped back (tf history cleared)", tf_listener_.clears());
  status.add("last problem", problem);
}

}  // namespace llc_ros
