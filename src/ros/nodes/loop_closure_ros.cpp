#include "laser_loop_closure/ros/nodes/loop_closure_ros.hpp"

#include <ros/package.h>

#include <algorithm>
#include <stdexcept>

#include "laser_loop_closure/ros/nodes/classifier_retraining.hpp"
#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/parameters.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

std::string LoopClosureNodeOptions::validate() const {
  if (odom_frame.empty()) return "odom_frame must not be empty";
  if (tf_queue_size < 1) return "tf_queue_size must be at least 1";
  if (queue_size < 1) return "queue_size must be at least 1";
  if (!(max_lag >= 0.0)) return "max_lag must not be negative";
  if (trained_model_path.empty()) return "trained_model_path must not be empty";
  if (publish_odometry_tf && use_wheel_odometry)
    return "publish_odometry_tf needs use_wheel_odometry false (with wheels, odom_frame is theirs)";
  if (wheel_odometry_wait_scans < 0) return "wheel_odometry_wait_scans must be 0 (wait for ever) or more";
  if (seq_reorder_scans < 0) return "seq_reorder_scans must be 0 (off) or more";
  // Not later than the scan: tf's filter lets a scan through once its own stamp's transform is
  // there, and a later one might not be yet.
  if (!(odometry_time_offset >= -1.0 && odometry_time_offset <= 0.0))
    return "odometry_time_offset must be in [-1, 0] s (odometry read at most 1 s before the scan's stamp)";
  return "";
}

namespace {
const char* failureName(tf2_ros::FilterFailureReason reason) {
  switch (reason) {
    case tf2_ros::filter_failure_reasons::OutTheBack: return "its stamp is older than the tf history";
    case tf2_ros::filter_failure_reasons::EmptyFrameID: return "it has no frame_id";
    default: return "dropped waiting for it (tf_queue_size full, or the transform failed)";
  }
}
}  // namespace

LoopClosureRos::LoopClosureRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : tf_listener_(tf_buffer_, nh), diagnostics_(nh, private_nh), nh_(nh) {
  loadNodeParameters(
      private_nh, "loop_closure", &options_,
      [](LoopClosureNodeOptions& o, ParameterReader& r) { visitLoopClosureParameters(o, r); }, &system_);
  options_.odom_frame = tfFrame(options_.odom_frame);  // "/odom" is tf1's spelling of "odom"
  if (options_.model_path.empty())
    options_.model_path = ros::package::getPath("laser_loop_closure") + "/config/classifier.yaml";
  llc::ClassifierModel model;
  try {
    model = llc::loadClassifierModel(options_.model_path);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("loop_closure: ") + e.what());
  }
  const llc::SlamOptions& slam = system_.slam;
  front_ = std::make_unique<llc::SlamFrontEnd>(model, slam.odometry, slam.aligner, slam.loops);
  std::unique_ptr<llc::OdometryTimeOffsetProbe> probe;
  if (options_.use_wheel_odometry && options_.estimate_odometry_time_offset)
    probe = std::make_unique<llc::OdometryTimeOffsetProbe>(llc::ScanOdometry(slam.odometry), llc::ScanAligner(slam.aligner),
                                                           options_.odometry_time_offset);
  wheels_ = std::make_unique<WheelOdometryReader>(tf_buffer_, options_.odom_frame, options_.odometry_time_offset, std::move(probe));
  model_path_ = options_.model_path;
  ROS_INFO("loop_closure: model %s (%zu stumps, K %.3f)", options_.model_path.c_str(), model.classifier.stumps().size(),
           model.classifier.thresholdK());

  llc::ScanBacklogOptions backlog;
  backlog.capacity = std::size_t(options_.queue_size);
  // Without wheels every scan is a step of the odometry chain: none is skipped to catch up.
  backlog.max_lag = options_.use_wheel_odometry ? options_.max_lag : 0.0;
  backlog_ = std::make_unique<llc::ScanBacklog<PendingScan>>(backlog);
  llc::SeqReorderOptions order;
  order.scans = options_.seq_reorder_scans;
  seq_order_ = llc::SeqReorder<PendingScan>(order);
  worker_ = std::thread([this] { work(); });

  keyframe_pub_ = nh.advertise<laser_loop_closure::Keyframe>("keyframes", 1000);
  loop_pub_ = nh.advertise<laser_loop_closure::LoopClosure>("loop_closures", 1000);
  if (options_.use_wheel_odometry) {
    // Outputs and failures come on nh's queue, never from tf's thread.
    odometry_filter_ = std::make_unique<tf2_ros::MessageFilter<laser_loop_closure::Scan360>>(
        tf_buffer_, options_.odom_frame, std::uint32_t(options_.tf_queue_size), nh);
    odometry_filter_->registerCallback(&LoopClosureRos::onScanWithOdometry, this);
    odometry_filter_->registerFailureCallback(
        [this](const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason) { onOdometryFailure(msg, reason); });
  }
  scan_sub_ = nh.subscribe("scan360", options_.queue_size, &LoopClosureRos::onScanReceived, this);
  path_sub_ = nh.subscribe("path", 1, &LoopClosureRos::onPath, this);
  session_sub_ = nh.subscribe("session", 1000, &LoopClosureRos::onSession, this);  // every part of a long session
  train_srv_ = service_thread_.handle(private_nh).advertiseService("train_classifier", &LoopClosureRos::trainClassifier, this);
  service_thread_.start();
  diagnostics_.setHardwareID("none");
  diagnostics_.add("loop closure", this, &LoopClosureRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) {
    releaseHeldScans();
    diagnostics_.force_update();
  });
}

LoopClosureRos::~LoopClosureRos() {
  service_thread_.stop();
  diagnostics_timer_.stop();
  scan_sub_.shutdown();
  odometry_filter_.reset();
  backlog_->stop();
  if (worker_.joinable()) worker_.join();
}

void LoopClosureRos::onScanReceived(const laser_loop_closure::Scan360::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  PendingScan pending;
  pending.msg = msg;
  pending.arrival = std::chrono::steady_clock::now();
  bool clear_filter = false;
  {
    std::lock_guard<std::mutex> lock(receive_mutex_);
    pending.index = scans_received_++;
    last_arrival_ = pending.arrival;
    const ros::Time stamp = msg->header.stamp;
    if (!newest_received_stamp_.isZero() && stamp + ros::Duration(kClockJumpBack) < newest_received_stamp_) {
      // A looped bag or a reset clock (TfListener clears the tf history on its own): scans
      // still waiting for odometry of the old pass will never get it.
      ++clock_jumps_back_;
      const std::size_t given_up = awaiting_odometry_.size();
      for (const auto& waiting : awaiting_odometry_) resolveInOrder(waiting.second.index, nullptr);
      awaiting_odometry_.clear();
      scans_given_up_at_jumps_ += given_up;
      clear_filter = odometry_filter_ != nullptr;
      ROS_WARN("loop_closure: scan stamps jumped back %.2f s (a looped bag or a reset clock): %zu scans waiting "
               "for odometry given up; mapping goes on in a new odometry chain",
               (newest_received_stamp_ - stamp).toSec(), given_up);
      newest_received_stamp_ = stamp;
    }
    newest_received_stamp_ = std::max(newest_received_stamp_, stamp);
    if (odometry_filter_ && !without_wheels_ && options_.wheel_odometry_wait_scans > 0 && filter_passed_ == 0 &&
        scans_received_ > std::size_t(options_.wheel_odometry_wait_scans)) {
      without_wheels_ = true;
      clear_filter = true;
      const std::size_t released = awaiting_odometry_.size();
      for (const auto& waiting : awaiting_odometry_) resolveInOrder(waiting.second.index, &waiting.second);
      awaiting_odometry_.clear();
      ROS_WARN("loop_closure: %d scans and not one odometry transform (%s -> '%s'): mapping without wheel odometry "
               "from now on (%zu scans still waiting included), and broadcasting %s -> '%s' from scan matching (set "
               "use_wheel_odometry false to say so, or wheel_odometry_wait_scans 0 to wait for the wheels)",
               options_.wheel_odometry_wait_scans, options_.odom_frame.c_str(), tfFrame(msg->header.frame_id).c_str(),
               released, options_.odom_frame.c_str(), tfFrame(msg->header.frame_id).c_str());
    }
    if (odometry_filter_ && !without_wheels_)
      awaiting_odometry_[msg.get()] = pending;
    else
      resolveInOrder(pending.index, &pending);
  }
  if (clear_filter) odometry_filter_->clear();
  if (odometry_filter_ && !without_wheels_) odometry_filter_->add(msg);  // on to onScanWithOdometry or onOdometryFailure
}

void LoopClosureRos::resolveInOrder(std::size_t index, const PendingScan* scan) {
  // The tf filter lets a scan go as soon as its transform is in the buffer, so after a gap in
  // the odometry a new scan can pass before older ones that waited; the front end must see
  // them in the order they came (out of order, they would look like time going back).
  resolved_[index] = scan ? std::optional<PendingScan>(*scan) : std::nullopt;
  while (!resolved_.empty()) {
    auto next = resolved_.begin();
    if (next->first == next_release_) {
      if (next->second) enqueue(std::move(*next->second));
      resolved_.erase(next);
      ++next_release_;
      continue;
    }
    // A newer scan is through while the next one still waits. Its transform may be in the
    // buffer already (the filter tells it a moment later): take it now. If not, it never comes
    // (tf interpolates, so a newer scan's transform covers every stamp since the oldest kept),
    // and waiting would hold every newer scan back: give it up.
    const auto waiting = std::find_if(awaiting_odometry_.begin(), awaiting_odometry_.end(),
                                      [&](const auto& a) { return a.second.index == next_release_; });
    if (waiting == awaiting_odometry_.end()) break;  // not yet numbered here: cannot happen
    PendingScan head = waiting->second;
    awaiting_odometry_.erase(waiting);
    std::string error;
    head.has_wheel_odometry = wheels_->read(*head.msg, &head.wheel_odometry, &error);
    if (head.has_wheel_odometry) {
      ++filter_passed_;
      resolved_[head.index] = head;
    } else {
      ++given_up_behind_newer_;
      last_filter_problem_ = "no wheel odometry while a newer scan had it: " + error;
      resolved_[head.index] = std::nullopt;
    }
  }
}

void LoopClosureRos::onScanWithOdometry(const laser_loop_closure::Scan360::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(receive_mutex_);
  const auto found = awaiting_odometry_.find(msg.get());
  if (found == awaiting_odometry_.end()) return;  // released without wheels, or given up at a jump back
  PendingScan pending = found->second;
  awaiting_odometry_.erase(found);
  ++filter_passed_;
  // The filter saw the transform in the buffer: this lookup does not wait.
  std::string error;
  pending.has_wheel_odometry = wheels_->read(*msg, &pending.wheel_odometry, &error);
  if (!pending.has_wheel_odometry) {
    ++lookup_failed_;
    last_filter_problem_ = "no wheel odometry: " + error;
    ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped, no wheel odometry (%s -> %s): %s", options_.odom_frame.c_str(),
                      msg->header.frame_id.c_str(), error.c_str());
    resolveInOrder(pending.index, nullptr);
    return;
  }
  resolveInOrder(pending.index, &pending);
}

void LoopClosureRos::onOdometryFailure(const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason) {
  const std::string why = std::string("no wheel odometry (") + options_.odom_frame + " -> '" + msg->header.frame_id +
                          "' at the scan's stamp): " + failureName(reason);
  {
    std::lock_guard<std::mutex> lock(receive_mutex_);
    const auto found = awaiting_odometry_.find(msg.get());
    if (found == awaiting_odometry_.end()) return;  // released without wheels, or given up at a jump back
    const std::size_t index = found->second.index;
    awaiting_odometry_.erase(found);
    ++filter_failed_;
    last_filter_problem_ = why;
    resolveInOrder(index, nullptr);
  }
  ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped, %s", why.c_str());
}

void LoopClosureRos::enqueue(PendingScan scan) {
  std::vector<PendingScan> due;
  if (!options_.use_wheel_odometry || without_wheels_) {
    // The scans before a scan predict it: their order is the motion's clock (llc::SeqReorder).
    const llc::SeqReorderCounters before = seq_order_.counters();
    const std::uint32_t seq = scan.msg->front_seq;  // read before the scan moves on
    seq_order_.push(seq, std::move(scan), &due);
    const llc::SeqReorderCounters& now = seq_order_.counters();
    if (now.out_of_order_seen && !before.out_of_order_seen)
      ROS_WARN("loop_closure: a scan came after one its driver numbered higher (header.seq): without wheel odometry "
               "the scans are put back in that order from now on, up to seq_reorder_scans %d held", options_.seq_reorder_scans);
    if (now.late_skipped > before.late_skipped)
      ROS_WARN_THROTTLE(5.0, "loop_closure: a scan came after its place in header.seq order had passed: skipped (%zu so far)",
                        now.late_skipped);
  } else {
    due.push_back(std::move(scan));
  }
  toBacklog(due);
}

void LoopClosureRos::releaseHeldScans() {
  std::lock_guard<std::mutex> lock(receive_mutex_);
  if (seq_order_.held() == 0 || std::chrono::steady_clock::now() - last_arrival_ < std::chrono::milliseconds(500)) return;
  std::vector<PendingScan> due;
  seq_order_.flush(&due);
  toBacklog(due);
}

void LoopClosureRos::toBacklog(std::vector<PendingScan>& due) {
  for (PendingScan& next : due) {
    const double stamp = next.msg->header.stamp.toSec();
    if (backlog_->push(std::move(next), stamp) > 0)
      ROS_WARN_THROTTLE(5.0, "loop_closure: %d scans wait for the front end: one where they lie closest in time was dropped (queue_size)%s",
                        options_.queue_size, options_.use_wheel_odometry ? "" : "; without wheel odometry the chain's steps grow longer");
  }
}

void LoopClosureRos::work() {
  PendingScan pending;
  while (backlog_->pop(&pending)) {
    processScan(pending);
    scan_latency_.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - pending.arrival).count());
    pending = PendingScan{};  // let go of the message while waiting
  }
}

void LoopClosureRos::processScan(const PendingScan& pending) {
  std::lock_guard<std::mutex> lock(mutex_);
  const laser_loop_closure::Scan360& msg = *pending.msg;
  std::string error;
  llc::Scan scan;
  if (!fromScan360(msg, &scan, &error)) {
    ++malformed_;
    last_problem_ = error;
    ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped: %s", error.c_str());
    return;
  }
  llc::Pose2 wheel_odometry = pending.wheel_odometry;
  if (pending.has_wheel_odometry && wheels_->estimate(msg, scan, &wheel_odometry)) {
    const llc::OdometryTimeOffsetProbeResult& r = *wheels_->estimateResult();
    if (r.estimate.ok)
      ROS_INFO("loop_closure: wheel odometry read %.3f s from each scan's stamp from now on (estimate_odometry_time_offset: %s)",
               r.offset, r.estimate.reason.c_str());
    else
      ROS_WARN("loop_closure: the odometry time offset stays %.3f s: %s", r.offset, r.estimate.reason.c_str());
  }
  llc::Keyframe keyframe = llc::makeKeyframe(std::move(scan), pending.index, pending.has_wheel_odometry ? &wheel_odometry : nullptr);
  const llc::FrontEndStep step = front_->addScan(keyframe.scan, keyframe.has_wheel_odometry ? &keyframe.wheel_odometry : nullptr);
  if (!step.skip_reason.empty()) {
    last_problem_ = step.skip_reason;
    ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped: %s", step.skip_reason.c_str());
    return;
  }
  if (!step.time_jump.empty()) ROS_WARN("loop_closure: scan %zu: %s", pending.index, step.time_jump.c_str());
  if (!step.wheel_jump.empty()) ROS_WARN_THROTTLE(5.0, "loop_closure: scan %zu: %s", pending.index, step.wheel_jump.c_str());
  if (options_.publish_odometry_tf || without_wheels_) publishOdometry(step, msg.header, &keyframe);
  if (!step.keyframe) return;
  // Keyframe first: the back end must know both ends of a loop before it applies it.
  laser_loop_closure::Keyframe keyframe_msg = toKeyframeMsg(keyframe, step.keyframe_index, step.odometry, msg.header.frame_id);
  keyframe_msg.features = front_->detector().features(step.keyframe_index);
  keyframe_msg.loops_before = loops_published_;
  keyframe_pub_.publish(keyframe_msg);
  llc::CandidateCheck place_gate;
  if (system_.slam.place_gate.enabled) {
    const std::size_t k = step.keyframe_index;
    place_gate = [this, k](std::size_t from, std::size_t to) { return placeCheck(from, to, k); };
  }
  llc::NearbyKeyframes nearby;
  if (system_.slam.loops.nearby_candidates > 0) {
    nearby = [this](std::size_t index, std::size_t before, double max_distance, double max_std, std::size_t count) {
      return nearbyKeyframes(index, before, max_distance, max_std, count);
    };
  }
  const llc::LoopDetectionResult loops = front_->detectLoops(step.keyframe_index, place_gate, nearby);
  for (const llc::LoopClosure& loop : loops.aligned) {
    loop_pub_.publish(toLoopClosureMsg(loop, msg.header));
    ++loops_published_;
    ++refusals_[std::size_t(loop.refusal)];
  }
  for (const llc::LoopClosure& skipped : loops.not_aligned) ++refusals_[std::size_t(skipped.refusal)];
}

template <class Service>
std::string LoopClosureRos::callBackEnd(ros::ServiceClient& client, ros::WallTime& retry, const std::string& name,
                                        Service& service) {
  const ros::WallTime now = ros::WallTime::now();
  if (!client.isValid() && now >= retry) {
    client = nh_.serviceClient<Service>(name, true);
    retry = now + ros::WallDuration(5.0);
  }
  // The back end bounds its own wait, so this call returns; a back end that is not there fails at once.
  if (client.isValid() && client.call(service) && service.response.answered) return "";
  const std::string why = !client.isValid() ? "no connection" : service.response.message.empty() ? "the call failed" : service.response.message;
  if (!client.isValid() || service.response.message.empty()) client.shutdown();
  return why;
}

llc::LoopVerdict LoopClosureRos::placeCheck(std::size_t from, std::size_t to, std::size_t keyframe) {
  ++place_checks_;
  laser_loop_closure::PlaceCheck check;
  check.request.from_keyframe = std::uint32_t(from);
  check.request.to_keyframe = std::uint32_t(to);
  check.request.keyframes = std::uint32_t(keyframe + 1);
  check.request.loops = loops_published_;
  check.request.radius = system_.slam.place_gate.radius;
  const std::string why = callBackEnd(place_client_, place_client_retry_, options_.place_check_service, check);
  if (!why.empty()) {
    ++place_checks_unanswered_;
    ROS_WARN_THROTTLE(10.0, "loop_closure: the place gate got no answer from %s (%s): candidates are aligned ungated",
                      options_.place_check_service.c_str(), why.c_str());
    return {};
  }
  return llc::placeGateVerdict(system_.slam.place_gate, check.response.chi2);
}

std::vector<llc::NearbyKeyframe> LoopClosureRos::nearbyKeyframes(std::size_t keyframe, std::size_t before, double max_distance,
                                                         double max_std, std::size_t count) {
  ++nearby_asked_;
  laser_loop_closure::NearbyKeyframes ask;
  ask.request.keyframe = std::uint32_t(keyframe);
  ask.request.before = std::uint32_t(before);
  ask.request.count = std::uint32_t(count);
  ask.request.max_distance = max_distance;
  ask.request.max_std = max_std;
  ask.request.keyframes = std::uint32_t(keyframe + 1);
  ask.request.loops = loops_published_;
  const std::string why = callBackEnd(nearby_client_, nearby_client_retry_, options_.nearby_service, ask);
  if (!why.empty()) {
    ++nearby_unanswered_;
    ROS_WARN_THROTTLE(10.0, "loop_closure: %s gave no nearby keyframes (%s): only the classifier's candidates are aligned",
                      options_.nearby_service.c_str(), why.c_str());
    return {};
  }
  // Without a pose for each (an older back end), each is searched with no guess.
  const bool posed = ask.response.poses.size() == ask.response.nearby.size();
  std::vector<llc::NearbyKeyframe> nearby;
  for (std::size_t i = 0; i < ask.response.nearby.size(); ++i) {
    llc::NearbyKeyframe near;
    near.keyframe = ask.response.nearby[i];
    if (posed) near.has_pose = true, near.pose = fromPose2D(ask.response.poses[i]);
    nearby.push_back(near);
  }
  return nearby;
}

void LoopClosureRos::publishOdometry(const llc::FrontEndStep& step, const std_msgs::Header& scan_header, llc::Keyframe* keyframe) {
  // The scan's pose in the front end's own odometry frame (its chain of matched motions).
  if (!step.has_odometry_pose) return;
  const llc::Pose2& pose = step.odometry_pose;
  if (step.keyframe) {
    keyframe->has_wheel_odometry = true;  // the back end's map -> odom comes from it
    keyframe->wheel_odometry = pose;
  }
  if (scan_header.stamp <= last_odometry_stamp_) return;  // tf would warn about a repeated or older stamp
  last_odometry_stamp_ = scan_header.stamp;
  geometry_msgs::TransformStamped t;
  t.header.stamp = scan_header.stamp;
  t.header.frame_id = options_.odom_frame;
  t.child_frame_id = tfFrame(scan_header.frame_id);
  t.transform = toTransformMsg(pose);
  odometry_broadcaster_.sendTransform(t);
}

void LoopClosureRos::onPath(const nav_msgs::Path::ConstPtr& msg) {
  std::vector<llc::Pose2> poses;
  poses.reserve(msg->poses.size());
  for (const geometry_msgs::PoseStamped& pose : msg->poses) poses.push_back(toPose2(pose.pose));
  std::lock_guard<std::mutex> lock(mutex_);
  optimised_poses_ = std::move(poses);
}

void LoopClosureRos::onSession(const laser_loop_closure::Session::ConstPtr& msg) {
  llc_ros::AssembledSession session;
  std::string error;
  if (session_assembler_.add(*msg, &session, &error) == SessionAssembler::Status::kIncomplete) return;
  const std::vector<llc::Keyframe>& keyframes = session.keyframes;
  const std::vector<std::vector<double>>& features = session.features;
  std::lock_guard<std::mutex> lock(mutex_);
  bool recomputed = false;
  if (error.empty()) error = front_->restore(keyframes, features, msg->continue_odometry, &recomputed);
  if (!error.empty()) {
    last_problem_ = "session not restored: " + error;
    ROS_ERROR("loop_closure: the session from %s was not restored: %s", msg->path.c_str(), error.c_str());
    return;
  }
  keyframes_restored_ = keyframes.size();
  ROS_INFO("loop_closure: restored %zu keyframes from %s (%s%s)", keyframes.size(), msg->path.c_str(),
           msg->continue_odometry ? "odometry continues" : "the next keyframe starts a new chain",
           recomputed ? "; features recomputed: the session's were made with other feature parameters" : "");
}

bool LoopClosureRos::trainClassifier(laser_loop_closure::TrainClassifier::Request& request,
                                     laser_loop_closure::TrainClassifier::Response& response) {
  std::unique_lock<std::mutex> one_at_a_time(training_, std::try_to_lock);
  if (!one_at_a_time) {
    response.message = "not trained: another training is running";
    return true;
  }
  llc::ClassifierModel running;
  llc::TrainingSet session;
  std::string session_text;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running = front_->detector().model();
    if (request.data.empty() || request.with_session) {
      try {
        const llc::SelfTrainingSet own = front_->selfTrainingSet(optimised_poses_);
        session = own.set;
        session_text = "session: " + own.summary();
      } catch (const std::exception& e) {
        response.message = std::string("not trained: ") + e.what();
        return true;
      }
    }
  }
  ROS_INFO("loop_closure: training a classifier (%s)", request.data.empty() ? session_text.c_str() : "from files");
  RetrainingOutcome outcome = retrainClassifier(request, running, session, session_text, options_.trained_model_path);
  response = outcome.response;
  if (response.success && outcome.better_or_equal) {
    std::lock_guard<std::mutex> lock(mutex_);
    try {
      front_->detector().setModel(outcome.model);
      response.swapped = true;
      model_path_ = response.model_path;
      ++models_swapped_;
    } catch (const std::exception& e) {
      response.message += std::string("; not swapped: ") + e.what();
    }
  } else if (response.success) {
    response.message += "; not swapped: the running model is better on these pairs";
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    models_trained_ += response.success;
  }
  ROS_INFO("loop_closure: train_classifier: %s", response.message.c_str());
  return true;
}

void LoopClosureRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::size_t received = 0, passed = 0, failed = 0, lookup_failed = 0, awaiting = 0, behind_older = 0;
  std::size_t jumps_back = 0, given_up = 0, behind_newer = 0, at_scan_stamp = 0;
  std::string filter_problem;
  llc::SeqReorderCounters order;
  {
    std::lock_guard<std::mutex> lock(receive_mutex_);
    order = seq_order_.counters();
    received = scans_received_, passed = filter_passed_, failed = filter_failed_, lookup_failed = lookup_failed_;
    awaiting = awaiting_odometry_.size();
    behind_older = resolved_.size();
    jumps_back = clock_jumps_back_, given_up = scans_given_up_at_jumps_, behind_newer = given_up_behind_newer_;
    at_scan_stamp = wheels_->atScanStamp();
    filter_problem = last_filter_problem_;
  }
  const llc::ScanBacklogCounters backlog = backlog_->counters();
  std::lock_guard<std::mutex> lock(mutex_);
  const llc::FrontEndCounters& c = front_->counters();
  const std::string problem = last_problem_.empty() ? filter_problem : last_problem_;
  if (received == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no scan received yet");
  else if (c.keyframes == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no keyframe yet: " + problem);
  else if (options_.max_lag > 0.0 && backlog.lag > options_.max_lag)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "falling behind the scans: " + std::to_string(backlog.lag) + " s");
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "detecting loops");
  status.add("scans received", received);
  status.add("scans waiting for their odometry transform", awaiting);
  status.add("scans given their wheel odometry", passed);
  status.add("scans with odometry waiting for older ones (kept in order)", behind_older);
  status.add("scan stamps that jumped back (a looped bag)", jumps_back);
  status.add("tf stamps that jumped back (tf history cleared)", tf_listener_.clears());
  status.add("scans given up at a jump back (their odometry never came)", given_up);
  status.add("scans given up, no odometry while a newer scan had it", behind_newer);
  status.add("mapping without wheel odometry (none came)", without_wheels_ ? "yes" : "no");
  status.add("scans without wheel odometry", failed + lookup_failed);
  status.add("scans with odometry at their own stamp, none at stamp + odometry_time_offset", at_scan_stamp);
  if (const llc::OdometryTimeOffsetProbeResult* estimate = wheels_->estimateResult()) {
    const llc::OdometryTimeOffsetProbeResult& r = *estimate;
    status.add("odometry time offset (s)", r.offset);
    status.add("odometry time offset estimate",
               r.decided ? r.estimate.reason
                         : std::to_string(r.moving_pairs) + " of " + std::to_string(llc::OdometryTimeOffsetProbeOptions{}.pairs) +
                               " scan pairs so far (they come in turns and changes of speed)");
  }
  status.add("without wheels, scans came out of header.seq order", order.out_of_order_seen ? "yes" : "no");
  status.add("scans held for the ones before them in header.seq order", order.reordered);
  status.add("scans skipped, late for their place in header.seq order", order.late_skipped);
  status.add("scans waiting for the front end", backlog.waiting);
  status.add("lag behind the newest scan (s)", backlog.lag);
  status.add("largest lag (s)", backlog.largest_lag);
  status.add("scans dropped to catch up (max_lag)", backlog.dropped_behind);
  // Candidates refused, by the stage that refused them (llc::LoopRefusal's names).
  for (llc::LoopRefusal kind : {llc::LoopRefusal::kPlaceGate, llc::LoopRefusal::kCrfMatch, llc::LoopRefusal::kIcp,
                                llc::LoopRefusal::kValidation, llc::LoopRefusal::kOther})
    status.add(std::string("candidates refused: ") + llc::loopRefusalName(kind), refusals_[std::size_t(kind)]);
  status.add("keyframes of the last restored session", keyframes_restored_);
  callback_timing_.addTo(status, "scan callbacks");
  scan_latency_.addTo(status, "scan arrival to processed");
  status.add("scans dropped, queue full (queue_size)", backlog.dropped_full);
  status.add("scans processed", backlog.popped);
  status.add("malformed scans", malformed_);
  status.add("scans skipped by the front end", c.skipped_scans);
  for (std::size_t kind = 1; kind < llc::kScanRefusalKinds; ++kind)  // llc::ScanRefusal's names
    status.add(std::string("scans skipped: ") + llc::scanRefusalName(llc::ScanRefusal(kind)), c.scans_skipped[kind]);
  status.add("model", model_path_);
  status.add("models trained", models_trained_);
  status.add("models swapped in", models_swapped_);
  status.add("keyframes", c.keyframes);
  status.add("steps matched by ICP", c.matched_steps);
  status.add("steps from wheel odometry alone", c.wheel_steps);
  status.add("steps where ICP and wheels disagreed", c.disputed_steps);
  status.add("steps where the laser overruled the wheels", c.recovered_steps);
  status.add("keyframe steps matched from the tracked scans", c.tracked_steps);
  for (std::size_t kind = 1; kind < llc::kOdometryRefusalKinds; ++kind)  // llc::OdometryRefusal's names
    status.add(std::string("steps not matched: ") + llc::odometryRefusalName(llc::OdometryRefusal(kind)),
               c.steps_not_matched[kind]);
  status.add("wheel odometry jumps left out", c.wheel_jumps);
  status.add("scans with stalled wheel odometry (placed by the laser)", c.stalled_wheel_scans);
  status.add("laser steps matched from the last scan's pose (the prediction failed)", c.laser_fallback_steps);
  status.add("laser keyframe steps widened along an ambiguous direction", c.ambiguous_steps);
  status.add("scans disputed with the wheels, placed from the laser's prediction", c.scans_placed_by_prediction);
  status.add("keyframe steps realigned with no guess (ICP overlapped little)", c.realigned_steps);
  status.add("scans timed by counting (stamps jitter beyond max_stamp_jitter)", c.scans_counted);
  status.add("stamps that jumped back (new odometry chains)", c.time_jumps);
  status.add("pairs classified", c.pairs_classified);
  status.add("candidates", c.candidates);
  status.add("classifier threshold K", front_->detector().threshold());
  status.add("candidates kept from alignment by the place gate", c.not_aligned);
  status.add("place checks asked of the back end", place_checks_);
  status.add("place checks unanswered (aligned ungated)", place_checks_unanswered_);
  status.add("nearby keyframes asked of the back end", nearby_asked_);
  status.add("nearby keyframes unanswered (none aligned)", nearby_unanswered_);
  status.add("threshold calibration pairs", c.calibration_pairs);
  status.add("loops found", c.loops_found);
  status.add("nearby candidates aligned (the map's, not the classifier's)", c.nearby_aligned);
  status.add("nearby candidates found (aligned and validated)", c.nearby_found);
  status.add("loops checked against their context", c.context_checked);
  status.add("loops whose context was too small to check", c.context_unchecked);
  status.add("refused by alignment", c.refused_by_alignment);
  status.add("seconds classifying", c.seconds_classify);
  status.add("seconds aligning", c.seconds_align);
  status.add("last problem", problem);
}

}  // namespace llc_ros
