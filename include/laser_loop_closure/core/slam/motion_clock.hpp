// The clock of the front end's motion model (the velocity that predicts a scan without wheel
// odometry, or with stalled wheels): the scans' own stamps where they come at a steady rate,
// the count of scans times their mean interval where the stamps jitter. Old logs stamped a
// scan when it was written, not when it was taken: the Intel log's intervals scatter from
// -0.5 s to 1.4 s (median 0.09 s, mean 0.20 s) while the robot turns at a steady rate, and a
// velocity taken over stamps 35 ms apart predicted a turn of a radian.
#pragma once

#include <array>
#include <cstddef>

namespace llc {

class MotionClock {
 public:
  /// Recent intervals looked at, and how many are needed before the stamps can be judged.
  static constexpr std::size_t window = 64;
  static constexpr std::size_t min_intervals = 16;
  /// max_jitter: the median absolute deviation of the recent intervals, as a share of their
  /// median, above which scans are counted (0: always counted; infinity: stamps always).
  explicit MotionClock(double max_jitter = 0.5);
  /// The motion time of the next scan, whose stamp is `stamp` (one call per scan, in the order
  /// they come): the first scan's stamp, then on by each interval, or by the mean interval
  /// while the stamps jitter.
  double tick(double stamp);
  /// Starts again at `stamp` (a restored session, time that jumped back): nothing is known.
  void reset(double stamp);
  /// Whether the last tick counted a scan instead of reading its stamp.
  bool countingScans() const { return counting_; }
  /// Whether the last tick read a stamp judged steady: min_intervals seen, their median above
  /// 0, their jitter within max_jitter (a prediction from such stamps is as good as the motion).
  bool stampsSteady() const { return steady_; }

 private:
  double max_jitter_;
  std::array<double, window> intervals_{};
  std::array<double, window> scratch_{};  ///< for the median: no allocation per scan
  std::size_t count_ = 0, next_ = 0;
  bool started_ = false, counting_ = false, steady_ = false;
  double last_stamp_ = 0.0, time_ = 0.0;
  double offset_ = 0.0;  ///< motion time minus stamp, changed only while scans are counted
};

}  // namespace llc
