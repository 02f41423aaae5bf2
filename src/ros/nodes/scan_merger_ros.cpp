#include "laser_loop_closure/ros/nodes/scan_merger_ros.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "laser_loop_closure/ros/io/parameters.hpp"

namespace llc_ros {

std::string ScanMergerOptions::validate() const {
  if (base_frame.empty()) return "base_frame must not be empty";
  if (!(max_pair_gap > 0.0)) return "max_pair_gap must be positive";
  if (!(back_timeout >= max_pair_gap)) return "back_timeout must be at least max_pair_gap";
  if (output_beams < 8) return "output_beams must be at least 8";
  if (queue_size < 1) return "queue_size must be at least 1";
  if (mount_wait_scans < 0) return "mount_wait_scans must be 0 (never) or more";
  if (!std::isfinite(mount_x) || !std::isfinite(mount_y) || !std::isfinite(mount_yaw))
    return "mount_x, mount_y and mount_yaw must be finite";
  return "";
}

namespace {
ScanMergerOptions readOptions(const ros::NodeHandle& private_nh) {
  ScanMergerOptions options;
  loadNodeParameters(private_nh, "scan_merger", &options,
                     [](ScanMergerOptions& o, ParameterReader& r) { visitScanMergerParameters(o, r); });
  return options;
}
}  // namespace

ScanMergerRos::ScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : options_(readOptions(private_nh)),
      tf_listener_(tf_buffer_, nh),
      mounts_(tf_buffer_, options_.base_frame,
              FallbackMount{{options_.mount_x, options_.mount_y, options_.mount_yaw}, options_.mount_wait_scans}),
      diagnostics_(nh, private_nh) {
  front_filter_.subscribe(nh, "scan_front", options_.queue_size);
  back_filter_.subscribe(nh, "scan_back", options_.queue_size);
  sync_ = std::make_unique<message_filters::Synchronizer<Policy>>(Policy(options_.queue_size), front_filter_, back_filter_);
  sync_->getPolicy()->setMaxIntervalDuration(ros::Duration(options_.max_pair_gap));
  sync_->registerCallback(&ScanMergerRos::onPair, this);
  front_alone_sub_ = nh.subscribe("scan_front", options_.queue_size, &ScanMergerRos::onFront, this);
  back_watch_sub_ = nh.subscribe("scan_back", options_.queue_size, &ScanMergerRos::onBack, this);
  scan360_pub_ = nh.advertise<laser_loop_closure::Scan360>("scan360", 50);
  laser_pub_ = nh.advertise<sensor_msgs::LaserScan>("scan_merged", 10);
  diagnostics_.setHardwareID(options_.base_frame);
  diagnostics_.add("scan merger", this, &ScanMergerRos::diagnose);
  diagnostics_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_.force_update(); });
}

ScanMergerRos::Conversion ScanMergerRos::toBase(const sensor_msgs::LaserScan& msg, llc::Scan* scan, bool retry) {
  std::string error;
  ScannerMount mount;
  bool fell_back = false, waiting = false;
  const bool mounted = mounts_.lookup(msg.header.frame_id, &mount, &error, &fell_back, &waiting, !retry);
  if (fell_back)
    ROS_WARN("scan_merger: tf has no mounting of scanner frame '%s' on '%s' after %d scans: taking it to sit at "
             "x %.3f m, y %.3f m, yaw %.3f rad (parameters mount_x, mount_y, mount_yaw; set mount_wait_scans 0 to "
             "wait for tf instead)",
             tfFrame(msg.header.frame_id).c_str(), mounts_.baseFrame().c_str(), options_.mount_wait_scans, options_.mount_x,
             options_.mount_y, options_.mount_yaw);
  if (!mounted && waiting) return Conversion::kWaiting;  // held; tf's /tf_static may come a moment after the scan
  if (!mounted || !toBaseScan(msg, mount, scan, &error)) {
    ++rejected_;
    // A new kind of problem is said at once; the same one again at most every 5 s.
    if (error != last_problem_)
      ROS_WARN("scan_merger: scan from '%s' skipped: %s", msg.header.frame_id.c_str(), error.c_str());
    else
      ROS_WARN_THROTTLE(5.0, "scan_merger: scan from '%s' skipped: %s", msg.header.frame_id.c_str(), error.c_str());
    last_problem_ = error;
    return Conversion::kRefused;
  }
  noteGeometry(msg);
  range_max_ = std::max(range_max_, msg.range_max);
  range_min_ = range_min_ == 0.0f ? msg.range_min : std::min(range_min_, msg.range_min);
  return Conversion::kDone;
}

void ScanMergerRos::handle(const sensor_msgs::LaserScan::ConstPtr& front, const sensor_msgs::LaserScan::ConstPtr& back) {
  llc::Scan front_scan, back_scan;
  const Conversion f = toBase(*front, &front_scan, false);
  const Conversion b = back ? toBase(*back, &back_scan, false) : Conversion::kRefused;
  if (f == Conversion::kRefused) return;
  if (f == Conversion::kWaiting || b == Conversion::kWaiting || !awaiting_mount_.empty()) {
    // Behind scans that wait for their mount: in order, or not at all.
    awaiting_mount_.push_back({front, b == Conversion::kRefused ? nullptr : back});
    // Held until tf tells the mount or the fallback mount is taken (after mount_wait_scans
    // scans): the first scans of a bag come before its /tf_static, or with no tf at all. Beyond
    // that many (or queue_size when waiting for tf for ever) the oldest is skipped.
    const std::size_t most_held = std::size_t(std::max(options_.queue_size, options_.mount_wait_scans + 1));
    while (awaiting_mount_.size() > most_held) {
      ++rejected_;
      last_problem_ = "no mounting of scanner frame '" + tfFrame(awaiting_mount_.front().first->header.frame_id) +
                      "' in tf yet (" + std::to_string(most_held) + " scans held)";
      ROS_WARN_THROTTLE(5.0, "scan_merger: scan skipped: %s", last_problem_.c_str());
      awaiting_mount_.pop_front();
    }
    publishAwaitingMount();
    return;
  }
  publish(front_scan, b == Conversion::kDone ? &back_scan : nullptr, *front);
}

void ScanMergerRos::publishAwaitingMount() {
  while (!awaiting_mount_.empty()) {
    const auto& [front, back] = awaiting_mount_.front();
    llc::Scan front_scan, back_scan;
    const Conversion f = toBase(*front, &front_scan, true);
    const Conversion b = back ? toBase(*back, &back_scan, true) : Conversion::kRefused;
    if (f == Conversion::kWaiting || b == Conversion::kWaiting) return;
    if (f == Conversion::kDone) publish(front_scan, b == Conversion::kDone ? &back_scan : nullptr, *front);
    awaiting_mount_.pop_front();
  }
}

void ScanMergerRos::onBack(const sensor_msgs::LaserScan::ConstPtr& /*back*/) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  last_back_arrival_ = ros::WallTime::now();
  fronts_before_any_back_.clear();  // two scanners: the synchroniser pairs them
  noteBackHeard();
}

void ScanMergerRos::noteBackHeard() {
  if (!back_silent_) return;
  back_silent_ = false;
  ROS_WARN("scan_merger: the back scanner talks again: merging front and back once more");
}

void ScanMergerRos::onPair(const sensor_msgs::LaserScan::ConstPtr& front, const sensor_msgs::LaserScan::ConstPtr& back) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  handle(front, back);  // a bad back scan leaves the front alone
}

void ScanMergerRos::onFront(const sensor_msgs::LaserScan::ConstPtr& front) {
  const auto timed = callback_timing_.measure();
  std::lock_guard<std::mutex> lock(mutex_);
  // While the back scanner talks, the synchroniser publishes; this path is for when it does not.
  // At the start a back scanner gets back_timeout to say something; the front scans of that
  // wait are held, not lost (a bag played at 8x sends 20 of them in 0.5 s).
  constexpr std::size_t kMostHeld = 1000;
  const ros::WallTime now = ros::WallTime::now();
  if (first_front_arrival_.isZero()) first_front_arrival_ = now;
  if (last_back_arrival_.isZero()) {
    if ((now - first_front_arrival_).toSec() <= options_.back_timeout) {
      if (fronts_before_any_back_.size() < kMostHeld) fronts_before_any_back_.push_back(front);
      return;
    }
    for (const auto& held : fronts_before_any_back_) handle(held, nullptr);
    fronts_before_any_back_.clear();
  } else if ((now - last_back_arrival_).toSec() <= options_.back_timeout) {
    return;
  } else if (!back_silent_) {
    back_silent_ = true;
    ++back_outages_;
    ROS_WARN("scan_merger: no back scan for %.2f s of wall time: publishing the front scanner alone until the back "
             "one talks again",
             (now - last_back_arrival_).toSec());
  }
  handle(front, nullptr);
}

void ScanMergerRos::noteGeometry(const sensor_msgs::LaserScan& msg) {
  const Geometry now{msg.ranges.size(), msg.angle_min, msg.angle_increment};
  const std::string frame = tfFrame(msg.header.frame_id);
  const auto known = geometry_.find(frame);
  if (known == geometry_.end()) {
    geometry_.emplace(frame, now);
    return;
  }
  if (!(known->second != now)) return;
  // Once per scanner: each scan carries its geometry and is converted with its own.
  if (geometry_changes_per_frame_[frame]++ == 0)
    ROS_WARN("scan_merger: scanner '%s' changed its geometry (%zu beams from %.4f rad by %.5f rad, now %zu from "
             "%.4f by %.5f): each scan is converted with its own (said once per scanner)",
             frame.c_str(), known->second.beams, known->second.angle_min, known->second.angle_increment, now.beams,
             now.angle_min, now.angle_increment);
  ++geometry_changes_;
  known->second = now;
}

void ScanMergerRos::publish(const llc::Scan& front, const llc::Scan* back, const sensor_msgs::LaserScan& front_msg) {
  std_msgs::Header header = front_msg.header;
  header.frame_id = mounts_.baseFrame();
  // A scan not newer than the last one (the front went alone while the back was only late) is
  // skipped; a jump back of a second or more is a restart (a looped bag) and goes through.
  if (!last_published_stamp_.isZero() && header.stamp <= last_published_stamp_ &&
      (last_published_stamp_ - header.stamp).toSec() < 1.0) {
    ++out_of_order_;
    ROS_WARN_THROTTLE(5.0, "scan_merger: a scan not newer than the last one published was skipped (%zu so far)", out_of_order_);
    return;
  }
  last_published_stamp_ = header.stamp;
  const llc::Scan merged = back ? llc::mergeScans(front, *back) : front;
  ++(back ? merged_ : front_only_);
  laser_loop_closure::Scan360 scan360 = toScan360(merged, header);
  // The driver's numbering, for loop_closure without wheels (llc::SeqReorder): header.seq
  // itself does not survive, roscpp numbers every message it sends anew.
  scan360.front_seq = front_msg.header.seq;
  scan360_pub_.publish(scan360);
  if (laser_pub_.getNumSubscribers() > 0) {
    llc::ScanMergeOptions resample;
    resample.output_beams = std::size_t(options_.output_beams);
    laser_pub_.publish(toLaserScan(llc::mergeScans(front, back ? *back : llc::Scan{}, resample), header, range_min_, range_max_));
  }
}

void ScanMergerRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (merged_ + front_only_ == 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no scan published yet");
  else if (rejected_ > 0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "some scans skipped: " + last_problem_);
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "merging");
  status.add("merged scans", merged_);
  status.add("front-only scans", front_only_);
  status.add("skipped scans", rejected_);
  status.add("scanner frames on the fallback mount", mounts_.fallbacks());
  status.add("skipped scans, not newer than the last", out_of_order_);
  status.add("scans held for their scanner's mount in tf", awaiting_mount_.size());
  status.add("scan geometry changes (beams, first angle or increment)", geometry_changes_);
  status.add("back scanner silent, front published alone", back_silent_ ? "yes" : "no");
  status.add("back scanner outages", back_outages_);
  callback_timing_.addTo(status, "scan callbacks");
  status.add("last problem", last_problem_);
}

}  // namespace llc_ros
