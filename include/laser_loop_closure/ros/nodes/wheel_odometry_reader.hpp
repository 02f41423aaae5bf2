// The loop_closure nodelet's wheel odometry for a scan, from tf: at the scan's stamp plus
// odometry_time_offset (or at the stamp itself where tf holds nothing that early: a drive's first
// scans), and, with estimate_odometry_time_offset, at the offset llc::OdometryTimeOffsetProbe
// chooses once it has seen enough of the drive. `llc slam --bag`'s reader applies the same rules
// to the bag's /odom (bag_io.cpp); with tf filled by hand this is testable without a master.
#pragma once

#include <tf2_ros/buffer.h>

#include <cstddef>
#include <memory>
#include <string>

#include "laser_loop_closure/Scan360.h"

#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"

namespace llc_ros {

class WheelOdometryReader {
 public:
  /// `buffer` must outlive the reader. `probe`: the estimate (null: odometry_time_offset always).
  WheelOdometryReader(const tf2_ros::Buffer& buffer, std::string odom_frame, double odometry_time_offset,
                      std::unique_ptr<llc::OdometryTimeOffsetProbe> probe);

  /// At the scan's stamp + odometry_time_offset, or at the stamp where tf holds none there
  /// (counted: atScanStamp); false with tf's reason where tf holds neither. On
  /// canonicalWheelPose's grid. The receiving side calls it, once the tf filter let the scan by.
  bool read(const laser_loop_closure::Scan360& msg, llc::Pose2* pose, std::string* error);

  /// With a probe: shows it the scan (in the order the front end takes them) and, where the
  /// offset it returns is not odometry_time_offset, reads `wheel_odometry` there instead (tf
  /// holds it: no newer than the scan's own stamp). True when the probe chose at this scan.
  bool estimate(const laser_loop_closure::Scan360& msg, const llc::Scan& scan, llc::Pose2* wheel_odometry);

  /// Scans whose odometry was read at their own stamp (read's fallback).
  std::size_t atScanStamp() const { return at_scan_stamp_; }
  /// The estimate so far; null without a probe.
  const llc::OdometryTimeOffsetProbeResult* estimateResult() const { return probe_ ? &probe_->result() : nullptr; }

 private:
  const tf2_ros::Buffer& buffer_;
  std::string odom_frame_;
  double odometry_time_offset_;
  std::unique_ptr<llc::OdometryTimeOffsetProbe> probe_;
  std::size_t at_scan_stamp_ = 0;
};

}  // namespace llc_ros
