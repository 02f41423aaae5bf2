// The relations metric of Kümmerle et al. 2009 ("On measuring the accuracy of SLAM
// algorithms"): how far the estimated motion between two scans is from a reference relation,
// over many relations. Local and global accuracy in one figure, with no global alignment.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc {

/// The true motion of the robot from the scan stamped t1 to the scan stamped t2, in the frame
/// of the first (a line `t1 t2 x y z roll pitch yaw` of a .relations file; z, roll, pitch are 0).
/// The relations were found by aligning the scans, so the frame that moves is the scanner's:
/// in the benchmark's CARMEN logs the robot's pose is the scanner's.
struct Relation {
  double t1 = 0.0, t2 = 0.0;  ///< s
  Pose2 motion;
};

/// The scans of a run: every scan's stamp and raw odometry, and its estimated pose when the
/// run has one for it.
struct ScanTrack {
  std::vector<double> stamps;                ///< s, in the log's order (not necessarily sorted)
  std::vector<Pose2> odometry;               ///< the log's raw odometry, one per scan
  std::vector<std::optional<Pose2>> poses;   ///< estimated, one per scan (none: not placed)
  /// Each scan's scanner pose on the robot (the base frame), one per scan; empty: the scanner
  /// is the robot's own frame. A bag may mount it off the base (FR079's: 0.04 m ahead), and
  /// then the base's motion is not the relations' (a turn in place moves the scanner).
  std::vector<Pose2> scanner_mounts;
};

struct RelationErrorOptions {
  double stamp_tolerance = 1e-4;  ///< s; a relation's stamp names the scan this close to it
};

/// Scans found by stamp (a log's stamps need not be sorted).
class StampIndex {
 public:
  explicit StampIndex(std::vector<double> stamps);
  /// The scan stamped nearest to t, if within tolerance (s).
  std::optional<std::size_t> find(double t, double tolerance) const;

 private:
  std::vector<double> stamps_;
  std::vector<std::size_t> order_;  ///< scan indices by stamp
};

/// One evaluated relation.
struct RelationError {
  std::size_t relation = 0;            ///< its index in the relations given
  std::size_t scan1 = 0, scan2 = 0;    ///< the scans its stamps name
  double translation = 0.0;            ///< m: |estimated translation - true translation|
  double rotation = 0.0;               ///< rad: |estimated rotation - true rotation|, wrapped
  bool carried = false;                ///< an end had no pose of its own (see evaluateRelations)
};

struct RelationErrorResult {
  std::size_t relations = 0;      ///< given
  std::size_t evaluated = 0;      ///< with both ends found (errors.size())
  std::size_t unmatched = 0;      ///< a stamp that names no scan: not evaluated
  std::size_t carried = 0;        ///< evaluated with at least one end carried by raw odometry
  double translation_mean = 0.0, translation_std = 0.0, translation_max = 0.0;  ///< m
  double rotation_mean = 0.0, rotation_std = 0.0, rotation_max = 0.0;           ///< rad
  std::vector<RelationError> errors;
};

/// Evaluates each relation on the track: both ends' scans found by stamp; an end without an
/// estimated pose is carried from the nearest scan (in log order) that has one, by the raw
/// odometry between the two; a track with no pose at all evaluates nothing. Means and sample
/// standard deviations are over the evaluated relations. The motion compared is the
/// scanner's: each end's pose composed with its scan's mount. Throws std::invalid_argument
/// when the track's vectors differ in length (scanner_mounts may be empty).
RelationErrorResult evaluateRelations(const std::vector<Relation>& relations, const ScanTrack& track,
                                      const RelationErrorOptions& options = {});

}  // namespace llc
