#include "laser_loop_closure/core/slam/odometry_time_offset_probe.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace llc {

std::string OdometryTimeOffsetProbeOptions::validate() const {
  if (max_periods < 1 || max_periods > 10) return "max_periods must be in [1, 10]";
  if (period_scans < 2) return "period_scans must be at least 2";
  if (pairs < 10) return "pairs must be at least 10";
  if (!(min_motion >= 0.0)) return "min_motion must be >= 0";
  if (!(min_parting >= 0.0)) return "min_parting must be >= 0";
  if (!(max_seconds > 0.0 && max_seconds <= 1.0)) return "max_seconds must be in (0, 1]";
  return "";
}

OdometryTimeOffsetProbe::OdometryTimeOffsetProbe(const ScanOdometry& odometry, const ScanAligner& aligner, double initial,
                                                 const OdometryTimeOffsetProbeOptions& options)
    : odometry_(odometry), aligner_(aligner), options_(options) {
  const std::string error = options.validate();
  if (!error.empty()) throw std::invalid_argument("odometry time offset probe options: " + error);
  if (!std::isfinite(initial)) throw std::invalid_argument("odometry time offset probe: the initial offset must be finite");
  result_.offset = initial;
}

bool OdometryTimeOffsetProbe::readAt(const OdometryLookup& odometry_at, double offset, Pose2* pose) {
  return (offset != 0.0 && odometry_at(offset, pose)) || odometry_at(0.0, pose);
}

double OdometryTimeOffsetProbe::observe(double stamp, const Scan& scan, const OdometryLookup& odometry_at) {
  const std::size_t index = result_.scans++;
  if (result_.decided) return result_.offset;
  if (result_.period == 0.0) {
    if (previous_ && stamp > previous_->stamp) first_intervals_.push_back(stamp - previous_->stamp);
    if (!previous_) previous_ = std::make_unique<Previous>();
    previous_->stamp = stamp;
    if (first_intervals_.size() + 1 < options_.period_scans) return result_.offset;
    std::nth_element(first_intervals_.begin(), first_intervals_.begin() + long(first_intervals_.size() / 2),
                     first_intervals_.end());
    result_.period = first_intervals_[first_intervals_.size() / 2];
    first_intervals_.clear();
    previous_.reset();
    // Candidates 0, -1, .. periods back, as far as max_seconds reaches (0 always).
    const int reach = std::min(options_.max_periods, int(std::floor(options_.max_seconds / result_.period + 1e-9)));
    for (int k = 0; k >= -reach; --k) {
      OdometryOffsetScore score;
      score.offset = k;
      result_.estimate.scores.push_back(score);
    }
    return result_.offset;
  }
  Previous current;
  current.stamp = stamp;
  for (const OdometryOffsetScore& s : result_.estimate.scores) {
    Pose2 pose;
    if (!readAt(odometry_at, s.offset * result_.period, &pose)) {
      previous_.reset();  // no odometry here: no pair across this scan
      return result_.offset;
    }
    current.odometry.push_back(pose);
  }
  if (previous_ && previous_->scan && stamp > previous_->stamp) {
    const Pose2 motion = between(previous_->odometry.front(), current.odometry.front());
    // At steady speed every candidate predicts the same step: only the pairs where they part
    // (turns, changes of speed) can tell them apart, and only those are counted.
    // (In heading, which is what the choice compares.)
    double parting = 0.0;
    for (std::size_t k = 1; k < current.odometry.size(); ++k)
      parting = std::max(parting, std::abs(between(between(previous_->odometry[k], current.odometry[k]), motion).theta));
    const bool moving = std::hypot(motion.x, motion.y) >= options_.min_motion || std::abs(motion.theta) >= options_.min_motion;
    if (moving && parting >= options_.min_parting) {
      current.scan = aligner_.prepare(scan);
      scorePair(current);
    }
  }
  if (!current.scan) current.scan = aligner_.prepare(scan);
  previous_ = std::make_unique<Previous>(std::move(current));
  if (result_.moving_pairs >= options_.pairs) {
    decide();
    result_.decided_at_scan = index;
  }
  return result_.offset;
}

void OdometryTimeOffsetProbe::scorePair(const Previous& current) {
  for (std::size_t k = 0; k < result_.estimate.scores.size(); ++k) {
    const Pose2 guess = between(previous_->odometry[k], current.odometry[k]);
    addOffsetPair(odometry_.match(*previous_->scan, *current.scan, {guess, true}), guess, &result_.estimate.scores[k]);
  }
  ++result_.moving_pairs;
}

void OdometryTimeOffsetProbe::decide() {
  std::ostringstream unit;
  unit << std::setprecision(3) << " periods of " << result_.period << " s";
  pickBestOffset(&result_.estimate, unit.str());
  result_.decided = true;
  previous_.reset();
  // Where the scans cannot tell, the initial offset stays.
  if (result_.estimate.ok) result_.offset = result_.estimate.best_offset * result_.period;
}

}  // namespace llc
