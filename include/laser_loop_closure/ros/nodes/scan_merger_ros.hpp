// The scan_merger nodelet's object: a front and a back LaserScan paired by message_filters
// ApproximateTime, each moved into the base frame by its tf2 mounting, merged into one
// 360-degree scan (llc::mergeScans, as `llc slam --bag` does). The front scanner alone also
// works: when no back scan has arrived for back_timeout of wall time, the front goes alone.
// (Wall time, not stamps: under load one scanner's messages can arrive a few scans late, and a
// bag played at 4x makes 0.5 s of stamps only 0.125 s of delivery.) The published stream never
// goes back in time by less than a second: such a scan is skipped; a larger jump (a looped bag)
// is taken as a restart.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>

#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "laser_loop_closure/ros/io/tf_bridge.hpp"
#include "laser_loop_closure/ros/io/callback_timing.hpp"
#include "laser_loop_closure/ros/io/tf_listener.hpp"

namespace llc_ros {

struct ScanMergerOptions {
  std::string base_frame = "base_link";  ///< frame of the merged scan
  double max_pair_gap = 0.05;   ///< s; a front and a back scan further apart in time are not paired
  double back_timeout = 0.5;    ///< s of wall time with no back scan arriving: publish the front alone
  int output_beams = 720;       ///< beams of the published LaserScan over 360 degrees (constant size)
  int queue_size = 20;          ///< messages kept per subscription and synchroniser
  /// A scanner frame tf has no mounting for after mount_wait_scans of its scans (a bag with no
  /// /tf) is taken to sit here on the base frame, with one warning (0: wait for tf for ever).
  int mount_wait_scans = 20;
  double mount_x = 0.0;         ///< m
  double mount_y = 0.0;         ///< m
  double mount_yaw = 0.0;       ///< rad
  [[nodiscard]] std::string validate() const;
};

template <class Visit>
void visitScanMergerParameters(ScanMergerOptions& o, Visit&& visit) {
  visit("base_frame", o.base_frame);
  visit("max_pair_gap", o.max_pair_gap);
  visit("back_timeout", o.back_timeout);
  visit("output_beams", o.output_beams);
  visit("queue_size", o.queue_size);
  visit("mount_wait_scans", o.mount_wait_scans);
  visit("mount_x", o.mount_x);
  visit("mount_y", o.mount_y);
  visit("mount_yaw", o.mount_yaw);
}

class ScanMergerRos {
 public:
  /// Subscribes scan_front and scan_back, publishes scan360 and scan_merged (names relative
  /// to nh, remappable). Throws std::runtime_error on bad parameters.
  ScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh);

 private:
  using Policy = message_filters::sync_policies::ApproximateTime<sensor_msgs::LaserScan, sensor_msgs::LaserScan>;
  void onPair(const sensor_msgs::LaserScan::ConstPtr& front, const sensor_msgs::LaserScan::ConstPtr& back);
  void onFront(const sensor_msgs::LaserScan::ConstPtr& front);
  void onBack(const sensor_msgs::LaserScan::ConstPtr& back);
  enum class Conversion { kDone, kWaiting, kRefused };
  /// Converts one scanner's message into the base frame: kWaiting while tf has no mount for its
  /// frame yet (before mount_wait_scans: the scan is held), kRefused (warned, throttled) when it
  /// cannot be used. retry: a held scan tried again (not counted towards the fallback mount).
  Conversion toBase(const sensor_msgs::LaserScan& msg, llc::Scan* scan, bool retry);
  /// One front scan with its back one (or none): published, held behind scans that wait for
  /// their mount, or skipped.
  void handle(const sensor_msgs::LaserScan::ConstPtr& front, const sensor_msgs::LaserScan::ConstPtr& back);
  /// Publishes the held scans, oldest first, as far as their mounts are known now.
  void publishAwaitingMount();
  void publish(const llc::Scan& front, const llc::Scan* back, const sensor_msgs::LaserScan& front_msg);
  /// Warns once per scanner frame when its beam count, first angle or increment changes.
  void noteGeometry(const sensor_msgs::LaserScan& msg);
  /// The back scanner talks again after going silent: merging resumes (said once per outage).
  void noteBackHeard();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ScanMergerOptions options_;
  tf2_ros::Buffer tf_buffer_;
  TfListener tf_listener_;  ///< clears the buffer when tf stamps jump back (a looped bag)
  MountCache mounts_;
  message_filters::Subscriber<sensor_msgs::LaserScan> front_filter_, back_filter_;
  std::unique_ptr<message_filters::Synchronizer<Policy>> sync_;
  ros::Subscriber front_alone_sub_, back_watch_sub_;
  ros::Publisher scan360_pub_, laser_pub_;
  diagnostic_updater::Updater diagnostics_;
  ros::WallTimer diagnostics_timer_;  ///< wall time: told while the clock stands still too
  CallbackTiming callback_timing_;    ///< onFront, onBack, onPair (lock wait included)

  std::mutex mutex_;
  ros::WallTime last_back_arrival_, first_front_arrival_;
  ros::Time last_published_stamp_;
  float range_max_ = 0.0f, range_min_ = 0.0f;  ///< of the published LaserScan: the scanners' widest
  std::size_t merged_ = 0, front_only_ = 0, rejected_ = 0, out_of_order_ = 0;
  std::string last_problem_;
  /// Front scans that came before any back scan, held for back_timeout (then published alone) so
  /// that a front-only robot or bag loses none of its first scans.
  std::deque<sensor_msgs::LaserScan::ConstPtr> fronts_before_any_back_;
  /// (front, back or null) whose scanner mount tf has not told yet; at most max(queue_size, mount_wait_scans + 1).
  std::deque<std::pair<sensor_msgs::LaserScan::ConstPtr, sensor_msgs::LaserScan::ConstPtr>> awaiting_mount_;
  struct Geometry {
    std::size_t beams = 0;
    float angle_min = 0.0f, angle_increment = 0.0f;
    bool operator!=(const Geometry& o) const {
      return beams != o.beams || angle_min != o.angle_min || angle_increment != o.angle_increment;
    }
  };
  std::map<std::string, Geometry> geometry_;  ///< per scanner frame, the last scan's
  std::map<std::string, std::size_t> geometry_changes_per_frame_;
  std::size_t geometry_changes_ = 0, back_outages_ = 0;
  bool back_silent_ = false;  ///< the back scanner talked, then went quiet for back_timeout
};

}  // namespace llc_ros
