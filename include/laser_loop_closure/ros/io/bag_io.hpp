// Recorded drives as rosbags: the reader that lets every llc subcommand take a .bag, and the
// writer of the simulator's sim.bag. ROS types stay in here; callers see core types.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"
#include "laser_loop_closure/core/slam/seq_reorder.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"

namespace llc_ros {

/// Topics of a drive in a bag (the names sim.bag uses are the defaults).
struct BagTopics {
  std::string front = "/scan_front";    ///< sensor_msgs/LaserScan of the front scanner
  std::string back = "/scan_back";      ///< sensor_msgs/LaserScan of the back one (may be absent)
  std::string odom = "/odom";           ///< nav_msgs/Odometry, wheel odometry
  std::string truth = "/ground_truth";  ///< nav_msgs/Odometry, true poses (for labelling pairs)
};

struct BagReadOptions {
  BagTopics topics;
  /// Frame the scans are merged in; empty: the child_frame_id of the first odometry message,
  /// else "base_link".
  std::string base_frame;
  double max_merge_gap = 0.05;  ///< s; a back scan further in time from the front one is unused
  /// Where a scanner sits whose frame /tf_static does not mount on the base frame (a bag
  /// recorded without tf): identity, as the nodelets' mount_x/y/yaw default.
  llc::Pose2 fallback_mount;
  /// s added to each scan's stamp where its wheel odometry is read (interpolated): a scanner
  /// whose stamps come d s after the wheels' (stamped on arrival) wants -d. As the nodelets'
  /// odometry_time_offset; `llc slam --odometry-offset auto` suggests it.
  double odometry_time_offset = 0.0;
  /// When set (mapping with wheels), each scan is shown to it in order and its odometry read at
  /// the offset it returns: the nodelets' estimate_odometry_time_offset (odometry_time_offset
  /// above is then its initial offset). Not owned.
  llc::OdometryTimeOffsetProbe* odometry_time_offset_probe = nullptr;
  /// Skip the front scans that the nodelets give up for want of odometry: those whose own
  /// stamp lies before the first or after the last odometry message (tf never extrapolates),
  /// counted in the report. For mapping with wheel odometry, so that `llc slam --bag` sees the
  /// scans the nodelets see; off, such a scan gets the first or last reading (held).
  bool skip_scans_outside_odometry = false;
  /// Mapping without wheel odometry (or the bag has none): the front scans are put back in their
  /// header.seq order as the loop_closure nodelet does (llc::SeqReorder; its seq_reorder_scans),
  /// after the scans not newer than the one before are skipped (as scan_merger skips them).
  bool without_wheels = false;
  llc::SeqReorderOptions seq_reorder{0};  ///< off unless asked for (llc slam asks: --seq-reorder-scans)
};

/// What the reader met besides the scans it returns.
struct BagReadReport {
  std::size_t front_messages = 0, back_messages = 0, odom_messages = 0, truth_messages = 0;
  std::size_t skipped_scans = 0;  ///< front scans that could not be used (reason in first_problem)
  /// Of those, scans outside the odometry's time span (skip_scans_outside_odometry).
  std::size_t scans_outside_odometry = 0;
  std::string first_problem;
  /// Messages whose bytes do not hold their type (a length beyond them: serializedMessageFits),
  /// left out; the first described in first_damaged.
  std::size_t damaged_messages = 0;
  std::string first_damaged;
  bool truth_from_odometry = false;  ///< no truth topic: poses for labelling came from odometry
  std::vector<std::string> fallback_frames;  ///< scanner frames /tf_static did not mount: on fallback_mount
  llc::SeqReorderCounters seq_reorder;  ///< without wheels: scans put back in header.seq order (those late are in skipped_scans)
};

/// A bag that cannot be read as a drive; what() names the file and the problem.
class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One scan per usable front LaserScan, in bag order (index = position among them), merged
/// with the back scan nearest in time within max_merge_gap into a 360-degree scan in the base
/// frame. Scanner mountings come from /tf_static (level or upside-down mounts; a tilted one is
/// an error). Truth and odometry poses are interpolated at each scan's stamp (the odometry at the
/// stamp + odometry_time_offset, or, as the nodelets do, at the stamp itself where the odometry
/// does not reach stamp + offset but reaches the stamp; a non-finite offset is a BagError). Front scans
/// that are malformed (see toScan) or older than the scan before them are skipped and counted;
/// without wheels, the rest are then put in header.seq order (see without_wheels).
llc::ScanSequence readBagSequence(const std::string& path, const BagReadOptions& options = {},
                                  BagReadReport* report = nullptr);

/// Seconds added to the simulator's clock in sim.bag (ROS time 0 means "no time" to tf).
constexpr double kSimBagEpoch = 1600000000.0;

/// Writes a simulated drive as a bag: LaserScan on /scan_front and /scan_back (frames
/// laser_front, laser_back; +inf where nothing returned), nav_msgs/Odometry on /odom (odom ->
/// base_link) and /ground_truth (world -> base_link), /tf odom -> base_link per frame, and the
/// mountings on /tf_static (latched). Throws BagError when the file cannot be written.
void writeSimBag(const llc::SimDrive& drive, const std::string& path);

/// One robot of a simulated fleet: its drive (often a part of one), its namespace ("" for
/// none), the frame its odometry is given in (anywhere: no relative prior between robots), and
/// seconds added to its stamps (parts of one drive played at once).
struct SimBagRobot {
  const llc::SimDrive* drive = nullptr;
  std::string ns;
  llc::Pose2 odometry_frame;
  double time_shift = 0.0;
};
/// writeSimBag's messages for every robot under its namespace: topics /ns/scan_front,
/// /ns/scan_back, /ns/odom, /ns/ground_truth (world -> ns/base_link), frames ns/odom,
/// ns/base_link, ns/laser_front, ns/laser_back on /tf; one latched /tf_static with every mount.
/// Throws BagError when the file cannot be written.
void writeSimFleetBag(const std::vector<SimBagRobot>& robots, const std::string& path);

}  // namespace llc_ros
