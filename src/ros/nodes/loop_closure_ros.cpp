#include "laser_loop_closure/ros/nodes/loop_closure_ros.hpp"

#include <ros/package.h>

#include <future>
#include <stdexcept>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/parameters.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"
#include "laser_loop_closure/ros/nodes/classifier_retraining.hpp"
#include "laser_loop_closure/ros/nodes/front_end_diagnostics.hpp"

namespace llc_ros {

std::string LoopClosureNodeOptions::validate() const {
  const std::string input_error = input.validate();
  if (!input_error.empty()) return input_error;
  if (trained_model_path.empty()) return "trained_model_path must not be empty";
  if (resend_keyframes < 0) return "resend_keyframes must not be negative";
  if (pack_beam_stride < 1) return "pack_beam_stride must be 1 or more";
  if (!(pack_range_step >= 1e-4 && pack_range_step <= 1.0)) return "pack_range_step must be 0.0001 to 1 m";
  if (publish_odometry_tf && input.use_wheel_odometry)
    return "publish_odometry_tf needs use_wheel_odometry false (with wheels, odom_frame is theirs)";
  return "";
}

LoopClosureRos::LoopClosureRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : tf_listener_(tf_buffer_, nh), diagnostics_(nh, private_nh) {
  loadNodeParameters(
      private_nh, "loop_closure", &options_,
      [](LoopClosureNodeOptions& o, ParameterReader& r) { visitLoopClosureParameters(o, r); }, &system_);
  options_.input.odom_frame = tfFrame(options_.input.odom_frame);  // "/odom" is tf1's spelling of "odom"
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
  back_end_ = std::make_unique<BackEndClient>(nh, options_.place_check_service, options_.nearby_service, slam.place_gate);
  wheels_ = makeWheelOdometryReader(tf_buffer_, options_.input, slam);
  state_.model_path = options_.model_path;
  publishState();
  ROS_INFO("loop_closure: model %s (%zu stumps, K %.3f)", options_.model_path.c_str(), model.classifier.stumps().size(),
           model.classifier.thresholdK());

  backlog_ = std::make_unique<llc::ScanBacklog<PendingScan>>(scanBacklogOptions(options_.input));
  worker_ = std::thread([this] { work(); });

  keyframe_pub_ = nh.advertise<laser_loop_closure::Keyframe>("keyframes", 1000);
  packed_keyframe_pub_ = nh.advertise<laser_loop_closure::PackedKeyframe>("packed_keyframes", 1000);
  loop_pub_ = nh.advertise<laser_loop_closure::LoopClosure>("loop_closures", 1000);
  sent_ = std::make_unique<ResendBuffer>(std::size_t(options_.resend_keyframes));
  resend_sub_ = nh.subscribe("resend_request", 10, &LoopClosureRos::onResendRequest, this);
  receiver_ = std::make_unique<ScanReceiver>("loop_closure", options_.input, tf_buffer_, nh, *wheels_, *backlog_);
  path_sub_ = nh.subscribe("path", 1, &LoopClosureRos::onPath, this);
  session_sub_ = nh.subscribe("session", 1000, &LoopClosureRos::onSession, this);  // every part of a long session
  train_srv_ = service_thread_.handle(private_nh).advertiseService("train_classifier", &LoopClosureRos::trainClassifier, this);
  service_thread_.start();
  diagnostics_.setHardwareID("none");
  diagnostics_.add("loop closure", this, &LoopClosureRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) {
    receiver_->releaseHeldScans();
    diagnostics_.force_update();
  });
}

LoopClosureRos::~LoopClosureRos() {
  service_thread_.stop();  // a training waits on the worker: it ends before the worker does
  diagnostics_timer_.stop();
  session_sub_.shutdown();
  backlog_->stop();  // the receiver may still push: a stopped backlog keeps what it gets
  if (worker_.joinable()) worker_.join();
  receiver_.reset();  // unsubscribes, waiting for a callback under way
}

void LoopClosureRos::work() {
  PendingScan pending;
  std::size_t drops_reported = 0;
  while (backlog_->pop(&pending)) {  // runs the tasks posted meanwhile first
    warnOfScansDroppedBehind("loop_closure", backlog_->counters(), options_.input.max_lag, &drops_reported);
    processScan(pending);
    scan_latency_.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - pending.arrival).count());
    pending = PendingScan{};  // let go of the message while waiting
    publishState();
  }
}

void LoopClosureRos::publishState() {
  state_.counters = front_->counters();
  state_.threshold = front_->detector().threshold();
  state_.scan_bytes = front_->detector().scanBytes();
  state_.feature_bytes = front_->detector().featureBytes();
  state_.prepared_held = front_->detector().heldPrepared();
  if (const llc::OdometryTimeOffsetProbeResult* estimate = wheels_ ? wheels_->estimateResult() : nullptr) state_.estimate = *estimate;
  std::lock_guard<std::mutex> lock(state_mutex_);
  published_ = state_;
}

template <class Result>
Result LoopClosureRos::onWorker(std::function<Result()> task) {
  auto job = std::make_shared<std::packaged_task<Result()>>(std::move(task));
  std::future<Result> result = job->get_future();
  backlog_->post([this, job] {
    (*job)();
    publishState();
  });
  return result.get();  // a task dropped at shutdown: std::future_error (broken promise)
}

void LoopClosureRos::processScan(const PendingScan& pending) {
  const laser_loop_closure::Scan360& msg = *pending.msg;
  std::string error;
  llc::Scan scan;
  llc::Pose2 wheel_odometry;
  if (!takeScan("loop_closure", pending, *wheels_, &scan, &wheel_odometry, &error)) {
    ++state_.malformed;
    state_.last_problem = error;
    ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped: %s", error.c_str());
    return;
  }
  llc::Keyframe keyframe = llc::makeKeyframe(std::move(scan), pending.index, pending.has_wheel_odometry ? &wheel_odometry : nullptr);
  const llc::FrontEndStep step = front_->addScan(keyframe.scan, keyframe.has_wheel_odometry ? &keyframe.wheel_odometry : nullptr);
  if (!step.skip_reason.empty()) {
    state_.last_problem = step.skip_reason;
    ROS_WARN_THROTTLE(5.0, "loop_closure: scan skipped: %s", step.skip_reason.c_str());
    return;
  }
  if (!step.time_jump.empty()) ROS_WARN("loop_closure: scan %zu: %s", pending.index, step.time_jump.c_str());
  if (!step.wheel_jump.empty()) ROS_WARN_THROTTLE(5.0, "loop_closure: scan %zu: %s", pending.index, step.wheel_jump.c_str());
  if (options_.publish_odometry_tf || receiver_->withoutWheels()) publishOdometry(step, msg.header, &keyframe);
  if (!step.keyframe) return;
  // Keyframe first: the back end must know both ends of a loop before it applies it.
  laser_loop_closure::Keyframe keyframe_msg = toKeyframeMsg(keyframe, step.keyframe_index, step.odometry, msg.header.frame_id);
  keyframe_msg.features = front_->detector().features(step.keyframe_index);
  keyframe_msg.loops_before = loops_published_;
  bool sent_packed = false;
  if (options_.pack_keyframes) {
    try {
      llc::ScanPackOptions packing;
      packing.beam_stride = std::size_t(options_.pack_beam_stride);
      packing.range_step = options_.pack_range_step;
      const laser_loop_closure::PackedKeyframe packed = packKeyframeMsg(keyframe_msg, keyframe.scan, packing);
      packed_keyframe_pub_.publish(packed);
      sent_->keyframe(packed);
      sent_packed = true;
    } catch (const std::exception& e) {  // sent as it is
      ROS_WARN_THROTTLE(5.0, "loop_closure: keyframe %zu not packed: %s", step.keyframe_index, e.what());
    }
  }
  if (!sent_packed) {
    keyframe_pub_.publish(keyframe_msg);
    sent_->keyframe(keyframe_msg);
  }
  llc::CandidateCheck place_gate;
  if (system_.slam.place_gate.enabled) {
    const std::size_t k = step.keyframe_index;
    place_gate = [this, k](std::size_t from, std::size_t to) { return back_end_->placeCheck(from, to, k, loops_published_); };
  }
  llc::NearbyKeyframes nearby;
  if (system_.slam.loops.nearby_candidates > 0) {
    nearby = [this](std::size_t index, std::size_t before, double max_distance, double max_std, std::size_t count) {
      return back_end_->nearbyKeyframes(index, before, max_distance, max_std, count, loops_published_);
    };
  }
  const llc::LoopDetectionResult loops = front_->detectLoops(step.keyframe_index, place_gate, nearby);
  for (const llc::LoopClosure& loop : loops.aligned) {
    const laser_loop_closure::LoopClosure loop_msg = toLoopClosureMsg(loop, msg.header);
    loop_pub_.publish(loop_msg);
    sent_->loop(loop_msg);
    ++loops_published_;
    ++state_.refusals[std::size_t(loop.refusal)];
  }
  for (const llc::LoopClosure& skipped : loops.not_aligned) ++state_.refusals[std::size_t(skipped.refusal)];
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
  t.header.frame_id = options_.input.odom_frame;
  t.child_frame_id = tfFrame(scan_header.frame_id);
  t.transform = toTransformMsg(pose);
  odometry_broadcaster_.sendTransform(t);
}

void LoopClosureRos::onResendRequest(const std_msgs::UInt32::ConstPtr& msg) {
  std::size_t gone = 0;
  const std::size_t sent = sent_->sendFrom(
      msg->data, [this](const laser_loop_closure::Keyframe& k) { keyframe_pub_.publish(k); },
      [this](const laser_loop_closure::PackedKeyframe& k) { packed_keyframe_pub_.publish(k); },
      [this](const laser_loop_closure::LoopClosure& l) { loop_pub_.publish(l); }, &gone);
  keyframes_sent_again_ += sent;
  ROS_INFO("loop_closure: the back end lacks keyframes from %u on: %zu sent again%s", msg->data, sent,
           gone > 0 ? (", " + std::to_string(gone) + " no longer kept (resend_keyframes)").c_str() : "");
}

void LoopClosureRos::onPath(const nav_msgs::Path::ConstPtr& msg) {
  std::vector<llc::Pose2> poses;
  poses.reserve(msg->poses.size());
  for (const geometry_msgs::PoseStamped& pose : msg->poses) poses.push_back(toPose2(pose.pose));
  std::lock_guard<std::mutex> lock(poses_mutex_);
  optimised_poses_ = std::move(poses);
}

void LoopClosureRos::onSession(const laser_loop_closure::Session::ConstPtr& msg) {
  auto session = std::make_shared<AssembledSession>();
  std::string error;
  if (session_assembler_.add(*msg, session.get(), &error) == SessionAssembler::Status::kIncomplete) return;
  const std::string path = msg->path;
  const bool continue_odometry = msg->continue_odometry;
  backlog_->post([this, session, error, path, continue_odometry]() mutable {
    bool recomputed = false;
    if (error.empty()) error = front_->restore(session->keyframes, session->features, continue_odometry, &recomputed);
    if (!error.empty()) {
      state_.last_problem = "session not restored: " + error;
      ROS_ERROR("loop_closure: the session from %s was not restored: %s", path.c_str(), error.c_str());
    } else {
      state_.keyframes_restored = session->keyframes.size();
      ROS_INFO("loop_closure: restored %zu keyframes from %s (%s%s)", session->keyframes.size(), path.c_str(),
               continue_odometry ? "odometry continues" : "the next keyframe starts a new chain",
               recomputed ? "; features recomputed: the session's were made with other feature parameters" : "");
    }
    publishState();
  });
}

bool LoopClosureRos::trainClassifier(laser_loop_closure::TrainClassifier::Request& request,
                                     laser_loop_closure::TrainClassifier::Response& response) {
  std::unique_lock<std::mutex> one_at_a_time(training_, std::try_to_lock);
  if (!one_at_a_time) {
    response.message = "not trained: another training is running";
    return true;
  }
  struct Start {
    llc::ClassifierModel running;
    llc::TrainingSet session;
    std::string session_text, error;
  };
  const bool with_session = request.data.empty() || request.with_session;
  const Start start = onWorker<Start>([this, with_session] {
    Start s;
    s.running = front_->detector().model();
    if (!with_session) return s;
    std::vector<llc::Pose2> poses;
    {
      std::lock_guard<std::mutex> lock(poses_mutex_);
      poses = optimised_poses_;
    }
    try {
      const llc::SelfTrainingSet own = front_->selfTrainingSet(poses);
      s.session = own.set;
      s.session_text = "session: " + own.summary();
    } catch (const std::exception& e) {
      s.error = e.what();
    }
    return s;
  });
  if (!start.error.empty()) {
    response.message = "not trained: " + start.error;
    return true;
  }
  ROS_INFO("loop_closure: training a classifier (%s)", request.data.empty() ? start.session_text.c_str() : "from files");
  RetrainingOutcome outcome = retrainClassifier(request, start.running, start.session, start.session_text, options_.trained_model_path);
  response = outcome.response;
  if (response.success && outcome.better_or_equal) {
    const std::string path = response.model_path;
    const std::string swap_error = onWorker<std::string>([this, &outcome, path] {
      try {
        front_->detector().setModel(outcome.model);
      } catch (const std::exception& e) {
        return std::string(e.what());
      }
      state_.model_path = path;
      ++state_.models_swapped;
      return std::string();
    });
    if (swap_error.empty()) response.swapped = true;
    else response.message += "; not swapped: " + swap_error;
  } else if (response.success) {
    response.message += "; not swapped: the running model is better on these pairs";
  }
  models_trained_ += response.success;
  ROS_INFO("loop_closure: train_classifier: %s", response.message.c_str());
  return true;
}

void LoopClosureRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  WorkerState w;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    w = published_;
  }
  const std::size_t received = receiver_->received();
  const llc::ScanBacklogCounters backlog = backlog_->counters();
  const std::string problem = w.last_problem.empty() ? receiver_->lastProblem() : w.last_problem;
  if (received == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no scan received yet");
  else if (w.counters.keyframes == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no keyframe yet: " + problem);
  else if (options_.input.max_lag > 0.0 && backlog.lag > options_.input.max_lag)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "falling behind the scans: " + std::to_string(backlog.lag) + " s");
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "detecting loops");
  receiver_->addTo(status);
  status.add("tf stamps that jumped back (tf history cleared)", tf_listener_.clears());
  status.add("keyframes sent again (resend_request)", keyframes_sent_again_.load());
  if (w.estimate) {
    status.add("odometry time offset (s)", w.estimate->offset);
    status.add("odometry time offset estimate",
               w.estimate->decided ? w.estimate->estimate.reason
                                   : std::to_string(w.estimate->moving_pairs) + " of " +
                                         std::to_string(llc::OdometryTimeOffsetProbeOptions{}.pairs) +
                                         " scan pairs so far (they come in turns and changes of speed)");
  }
  addBacklogTo(backlog, status);
  scan_latency_.addTo(status, "scan arrival to processed");
  // Candidates refused, by the stage that refused them (llc::LoopRefusal's names).
  for (llc::LoopRefusal kind : {llc::LoopRefusal::kPlaceGate, llc::LoopRefusal::kCrfMatch, llc::LoopRefusal::kIcp,
                                llc::LoopRefusal::kValidation, llc::LoopRefusal::kContext, llc::LoopRefusal::kOther})
    status.add(std::string("candidates refused: ") + llc::loopRefusalName(kind), w.refusals[std::size_t(kind)]);
  status.add("keyframes of the last restored session", w.keyframes_restored);
  status.add("bytes of the keyframes' scans at rest", w.scan_bytes);
  status.add("bytes of the keyframes' features", w.feature_bytes);
  status.add("keyframes kept prepared for alignment (loops/prepared_cache)", w.prepared_held);
  status.add("malformed scans", w.malformed);
  status.add("model", w.model_path);
  status.add("models trained", models_trained_.load());
  status.add("models swapped in", w.models_swapped);
  addFrontEndCounters(w.counters, w.threshold, status);
  back_end_->addTo(status);
  status.add("last problem", problem);
}

}  // namespace llc_ros
