#include "laser_loop_closure/ros/nodes/scan_receiver.hpp"

#include <algorithm>
#include <utility>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/tf_bridge.hpp"

namespace llc_ros {

std::string ScanInputOptions::validate() const {
  if (odom_frame.empty()) return "odom_frame must not be empty";
  if (tf_queue_size < 1) return "tf_queue_size must be at least 1";
  if (queue_size < 1) return "queue_size must be at least 1";
  if (!(max_lag >= 0.0)) return "max_lag must not be negative";
  if (wheel_odometry_wait_scans < 0) return "wheel_odometry_wait_scans must be 0 (wait for ever) or more";
  if (seq_reorder_scans < 0) return "seq_reorder_scans must be 0 (off) or more";
  // Not later than the scan: tf's filter lets a scan through once its own stamp's transform is
  // there, and a later one might not be yet.
  if (!(odometry_time_offset >= -1.0 && odometry_time_offset <= 0.0))
    return "odometry_time_offset must be in [-1, 0] s (odometry read at most 1 s before the scan's stamp)";
  return "";
}

std::unique_ptr<WheelOdometryReader> makeWheelOdometryReader(const tf2_ros::Buffer& buffer, const ScanInputOptions& options,
                                                             const llc::SlamOptions& slam) {
  std::unique_ptr<llc::OdometryTimeOffsetProbe> probe;
  if (options.use_wheel_odometry && options.estimate_odometry_time_offset)
    probe = std::make_unique<llc::OdometryTimeOffsetProbe>(llc::ScanOdometry(slam.odometry), llc::ScanAligner(slam.aligner),
                                                           options.odometry_time_offset);
  return std::make_unique<WheelOdometryReader>(buffer, options.odom_frame, options.odometry_time_offset, std::move(probe));
}

llc::ScanBacklogOptions scanBacklogOptions(const ScanInputOptions& options) {
  llc::ScanBacklogOptions backlog;
  backlog.capacity = std::size_t(options.queue_size);
  backlog.max_lag = options.use_wheel_odometry ? options.max_lag : 0.0;
  return backlog;
}

bool takeScan(const char* node, const PendingScan& pending, WheelOdometryReader& wheels, llc::Scan* scan,
              llc::Pose2* wheel_odometry, std::string* error) {
  if (!fromScan360(*pending.msg, scan, error)) return false;
  *wheel_odometry = pending.wheel_odometry;
  if (!pending.has_wheel_odometry || !wheels.estimate(*pending.msg, *scan, wheel_odometry)) return true;
  const llc::OdometryTimeOffsetProbeResult& r = *wheels.estimateResult();
  if (r.estimate.ok)
    ROS_INFO("%s: wheel odometry read %.3f s from each scan's stamp from now on (estimate_odometry_time_offset: %s)", node,
             r.offset, r.estimate.reason.c_str());
  else
    ROS_WARN("%s: the odometry time offset stays %.3f s: %s", node, r.offset, r.estimate.reason.c_str());
  return true;
}

void warnOfScansDroppedBehind(const char* node, const llc::ScanBacklogCounters& backlog, double max_lag,
                              std::size_t* reported) {
  if (backlog.dropped_behind <= *reported) return;
  ROS_WARN_THROTTLE(5.0, "%s: %zu scans dropped in all to catch up: the oldest waiting was more than max_lag (%.1f s) "
                    "behind the newest (the machine is too slow for the scans, or busy)",
                    node, backlog.dropped_behind, max_lag);
  *reported = backlog.dropped_behind;
}

void addBacklogTo(const llc::ScanBacklogCounters& backlog, diagnostic_updater::DiagnosticStatusWrapper& status) {
  status.add("scans waiting for the front end", backlog.waiting);
  status.add("lag behind the newest scan (s)", backlog.lag);
  status.add("largest lag (s)", backlog.largest_lag);
  status.add("scans dropped to catch up (max_lag)", backlog.dropped_behind);
  status.add("scans dropped, queue full (queue_size)", backlog.dropped_full);
  status.add("scans processed", backlog.popped);
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

ScanReceiver::ScanReceiver(std::string node, const ScanInputOptions& options, tf2_ros::Buffer& buffer, ros::NodeHandle nh,
                           WheelOdometryReader& wheels, llc::ScanBacklog<PendingScan>& backlog)
    : node_(std::move(node)), options_(options), wheels_(wheels), backlog_(backlog) {
  llc::SeqReorderOptions order;
  order.scans = options_.seq_reorder_scans;
  seq_order_ = llc::SeqReorder<PendingScan>(order);
  if (options_.use_wheel_odometry) {
    // Outputs and failures come on nh's queue, never from tf's thread.
    odometry_filter_ = std::make_unique<tf2_ros::MessageFilter<laser_loop_closure::Scan360>>(
        buffer, options_.odom_frame, std::uint32_t(options_.tf_queue_size), nh);
    odometry_filter_->registerCallback(&ScanReceiver::onScanWithOdometry, this);
    odometry_filter_->registerFailureCallback(
        [this](const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason) { onOdometryFailure(msg, reason); });
  }
  scan_sub_ = nh.subscribe("scan360", options_.queue_size, &ScanReceiver::onScanReceived, this);
}

ScanReceiver::~ScanReceiver() {
  scan_sub_.shutdown();
  odometry_filter_.reset();
}


void ScanReceiver::onScanReceived(const laser_loop_closure::Scan360::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  PendingScan pending;
  pending.msg = msg;
  pending.arrival = std::chrono::steady_clock::now();
  bool clear_filter = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
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
      ROS_WARN("%s: scan stamps jumped back %.2f s (a looped bag or a reset clock): %zu scans waiting "
               "for odometry given up; the scans go on in a new odometry chain", node_.c_str(),
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
      ROS_WARN("%s: %d scans and not one odometry transform (%s -> '%s'): going on without wheel odometry "
               "from now on (%zu scans still waiting included), and broadcasting %s -> '%s' from scan matching (set "
               "use_wheel_odometry false to say so, or wheel_odometry_wait_scans 0 to wait for the wheels)", node_.c_str(),
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

void ScanReceiver::resolveInOrder(std::size_t index, const PendingScan* scan) {
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
    head.has_wheel_odometry = wheels_.read(*head.msg, &head.wheel_odometry, &error);
    if (head.has_wheel_odometry) {
      ++filter_passed_;
      resolved_[head.index] = head;
    } else {
      ++given_up_behind_newer_;
      last_problem_ = "no wheel odometry while a newer scan had it: " + error;
      resolved_[head.index] = std::nullopt;
    }
  }
}

void ScanReceiver::onScanWithOdometry(const laser_loop_closure::Scan360::ConstPtr& msg) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = awaiting_odometry_.find(msg.get());
  if (found == awaiting_odometry_.end()) return;  // released without wheels, or given up at a jump back
  PendingScan pending = found->second;
  awaiting_odometry_.erase(found);
  ++filter_passed_;
  // The filter saw the transform in the buffer: this lookup does not wait.
  std::string error;
  pending.has_wheel_odometry = wheels_.read(*msg, &pending.wheel_odometry, &error);
  if (!pending.has_wheel_odometry) {
    ++lookup_failed_;
    last_problem_ = "no wheel odometry: " + error;
    ROS_WARN_THROTTLE(5.0, "%s: scan skipped, no wheel odometry (%s -> %s): %s", node_.c_str(), options_.odom_frame.c_str(),
                      msg->header.frame_id.c_str(), error.c_str());
    resolveInOrder(pending.index, nullptr);
    return;
  }
  resolveInOrder(pending.index, &pending);
}

void ScanReceiver::onOdometryFailure(const laser_loop_closure::Scan360::ConstPtr& msg, tf2_ros::FilterFailureReason reason) {
  const std::string why = std::string("no wheel odometry (") + options_.odom_frame + " -> '" + msg->header.frame_id +
                          "' at the scan's stamp): " + failureName(reason);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = awaiting_odometry_.find(msg.get());
    if (found == awaiting_odometry_.end()) return;  // released without wheels, or given up at a jump back
    const std::size_t index = found->second.index;
    awaiting_odometry_.erase(found);
    ++filter_failed_;
    last_problem_ = why;
    resolveInOrder(index, nullptr);
  }
  ROS_WARN_THROTTLE(5.0, "%s: scan skipped, %s", node_.c_str(), why.c_str());
}

void ScanReceiver::enqueue(PendingScan scan) {
  std::vector<PendingScan> due;
  if (!options_.use_wheel_odometry || without_wheels_) {
    // The scans before a scan predict it: their order is the motion's clock (llc::SeqReorder).
    const llc::SeqReorderCounters before = seq_order_.counters();
    const std::uint32_t seq = scan.msg->front_seq;  // read before the scan moves on
    seq_order_.push(seq, std::move(scan), &due);
    const llc::SeqReorderCounters& now = seq_order_.counters();
    if (now.out_of_order_seen && !before.out_of_order_seen)
      ROS_WARN("%s: a scan came after one its driver numbered higher (header.seq): without wheel odometry "
               "the scans are put back in that order from now on, up to seq_reorder_scans %d held", node_.c_str(), options_.seq_reorder_scans);
    if (now.late_skipped > before.late_skipped)
      ROS_WARN_THROTTLE(5.0, "%s: a scan came after its place in header.seq order had passed: skipped (%zu so far)", node_.c_str(),
                        now.late_skipped);
  } else {
    due.push_back(std::move(scan));
  }
  toBacklog(due);
}

void ScanReceiver::releaseHeldScans() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (seq_order_.held() == 0 || std::chrono::steady_clock::now() - last_arrival_ < std::chrono::milliseconds(500)) return;
  std::vector<PendingScan> due;
  seq_order_.flush(&due);
  toBacklog(due);
}

void ScanReceiver::toBacklog(std::vector<PendingScan>& due) {
  for (PendingScan& next : due) {
    const double stamp = next.msg->header.stamp.toSec();
    if (backlog_.push(std::move(next), stamp) > 0)
      ROS_WARN_THROTTLE(5.0, "%s: %d scans wait for the front end: one where they lie closest in time was dropped (queue_size)%s", node_.c_str(),
                        options_.queue_size, options_.use_wheel_odometry ? "" : "; without wheel odometry the chain's steps grow longer");
  }
}

std::size_t ScanReceiver::received() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return scans_received_;
}

std::string ScanReceiver::lastProblem() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_problem_;
}

void ScanReceiver::addTo(diagnostic_updater::DiagnosticStatusWrapper& status) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const llc::SeqReorderCounters& order = seq_order_.counters();
  status.add("scans received", scans_received_);
  status.add("scans waiting for their odometry transform", awaiting_odometry_.size());
  status.add("scans given their wheel odometry", filter_passed_);
  status.add("scans with odometry waiting for older ones (kept in order)", resolved_.size());
  status.add("scan stamps that jumped back (a looped bag)", clock_jumps_back_);
  status.add("scans given up at a jump back (their odometry never came)", scans_given_up_at_jumps_);
  status.add("scans given up, no odometry while a newer scan had it", given_up_behind_newer_);
  status.add("mapping without wheel odometry (none came)", without_wheels_ ? "yes" : "no");
  status.add("scans without wheel odometry", filter_failed_ + lookup_failed_);
  status.add("scans with odometry at their own stamp, none at stamp + odometry_time_offset", wheels_.atScanStamp());
  status.add("without wheels, scans came out of header.seq order", order.out_of_order_seen ? "yes" : "no");
  status.add("scans held for the ones before them in header.seq order", order.reordered);
  status.add("scans skipped, late for their place in header.seq order", order.late_skipped);
  callback_timing_.addTo(status, "scan callbacks");
}

}  // namespace llc_ros
