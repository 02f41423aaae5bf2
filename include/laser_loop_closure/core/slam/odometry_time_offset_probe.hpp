// A drive's wheel odometry stamped earlier than its scans, found while the drive goes on: the
// online form of estimateOdometryOffset, for a robot or a bag whose odometry is read by time
// (tf, /odom) rather than carried in each scan. The candidates are whole scan periods back
// (0, 1, .., max_periods), as the log estimate's whole scans are; each moving pair of
// consecutive scans where the candidates' steps part (a turn, a change of speed) is aligned by
// ICP from the odometry read at every candidate, as it comes, and after `pairs` such pairs the candidate that ICP corrects least is taken from then on.
// The scans before that keep the initial offset. The loop_closure nodelet and `llc slam --bag`
// feed the same scans in the same order, so both take the same offset at the same scan.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/slam/odometry_offset.hpp"
#include "laser_loop_closure/core/slam/scan_odometry.hpp"

namespace llc {

struct OdometryTimeOffsetProbeOptions {
  int max_periods = 3;              ///< candidates: the odometry read 0..max_periods scan periods before each stamp
  std::size_t period_scans = 10;    ///< the period is the median stamp interval of the first this many scans
  std::size_t pairs = 100;          ///< consecutive scan pairs scored before the choice (moving, candidates parting)
  double min_motion = 0.05;         ///< m or rad the odometry moved between the two scans; stiller pairs tell nothing
  /// rad; a pair counts where the candidates' steps part by this much in heading (at a steady
  /// turn rate they agree and tell nothing; less than this is the wheels' own noise)
  double min_parting = 0.01;
  double max_seconds = 1.0;         ///< candidates further back than this are not tried (the nodelets read at most 1 s back)
  [[nodiscard]] std::string validate() const;
};

/// The wheel odometry at one scan's stamp plus an offset (s); false where there is none
/// (before the first reading). The caller adds the offset to the stamp as it keeps time (ROS:
/// in whole nanoseconds), so that tf and a bag's reader read the same instant.
using OdometryLookup = std::function<bool(double offset, Pose2* pose)>;

/// What the probe found so far.
struct OdometryTimeOffsetProbeResult {
  bool decided = false;            ///< the choice is made (offset holds from decided_at_scan on)
  double offset = 0.0;             ///< s added to each scan's stamp where its odometry is read now
  double period = 0.0;             ///< s; 0 until period_scans scans came
  std::size_t scans = 0;           ///< scans observed
  std::size_t moving_pairs = 0;    ///< pairs scored so far
  std::size_t decided_at_scan = 0; ///< the first scan (0-based, among those observed) read at the chosen offset
  /// The scores, offset k meaning -k periods (the choice's reason in estimate.reason).
  OdometryOffsetResult estimate;
};

class OdometryTimeOffsetProbe {
 public:
  /// `initial`: the offset (s) used until the choice (the configured one). Throws
  /// std::invalid_argument when options.validate() finds a problem.
  OdometryTimeOffsetProbe(const ScanOdometry& odometry, const ScanAligner& aligner, double initial,
                          const OdometryTimeOffsetProbeOptions& options = {});

  /// The next scan with wheel odometry, in the order the front end takes them; returns the
  /// offset (s) at which this scan's odometry is to be read. `odometry_at` (this scan's) is
  /// asked at the candidates' offsets (and at 0 where one has no reading, as the nodelets fall back).
  double observe(double stamp, const Scan& scan, const OdometryLookup& odometry_at);

  const OdometryTimeOffsetProbeResult& result() const { return result_; }

  /// The odometry at the scan's stamp + offset, or at the stamp where that has none (a drive's
  /// first scans); false where neither has a reading. The nodelets' and the bag reader's rule.
  static bool readAt(const OdometryLookup& odometry_at, double offset, Pose2* pose);

 private:
  struct Previous {
    double stamp = 0.0;
    std::shared_ptr<const PreparedScan> scan;
    std::vector<Pose2> odometry;  ///< at each candidate
  };
  void scorePair(const Previous& current);
  void decide();

  ScanOdometry odometry_;
  ScanAligner aligner_;
  OdometryTimeOffsetProbeOptions options_;
  OdometryTimeOffsetProbeResult result_;
  std::vector<double> first_intervals_;
  std::unique_ptr<Previous> previous_;
};

}  // namespace llc
