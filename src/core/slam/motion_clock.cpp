#include "laser_loop_closure/core/slam/motion_clock.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace llc {

MotionClock::MotionClock(double max_jitter) : max_jitter_(max_jitter) {
  if (!(max_jitter >= 0.0)) throw std::invalid_argument("MotionClock: max_jitter must be >= 0");
}

void MotionClock::reset(double stamp) {
  count_ = next_ = 0;
  counting_ = steady_ = false;
  started_ = true;
  last_stamp_ = time_ = stamp;
  offset_ = 0.0;
}

double MotionClock::tick(double stamp) {
  if (!started_ || !std::isfinite(stamp)) {
    if (std::isfinite(stamp)) reset(stamp);
    return time_;
  }
  const double interval = stamp - last_stamp_;
  last_stamp_ = stamp;
  intervals_[next_] = interval;
  next_ = (next_ + 1) % window;
  count_ = std::min(count_ + 1, window);
  counting_ = steady_ = false;
  double mean = 0.0;
  if (count_ >= min_intervals) {
    const auto first = scratch_.begin(), last = first + std::ptrdiff_t(count_);
    std::copy(intervals_.begin(), intervals_.begin() + std::ptrdiff_t(count_), first);
    const auto middle = first + std::ptrdiff_t(count_ / 2);
    std::nth_element(first, middle, last);
    const double median = *middle;
    // The mean, not the median, is the interval counted by: jittering stamps bunch up (the
    // Intel log's median interval is 0.09 s, its mean 0.20 s, as its scanner's rate).
    for (auto value = first; value != last; ++value) mean += *value / double(count_);
    for (auto value = first; value != last; ++value) *value = std::abs(*value - median);
    std::nth_element(first, middle, last);
    // (No steady interval to count by, e.g. every stamp the same: the stamps as they are.)
    counting_ = median > 0.0 && mean > 0.0 && *middle > max_jitter_ * median;
    steady_ = median > 0.0 && !counting_;
  }
  // Exactly the stamps while they are steady; on by the mean interval, from where the clock
  // stood, while they jitter.
  if (counting_) time_ += mean, offset_ = time_ - stamp;
  else time_ = stamp + offset_;
  return time_;
}

}  // namespace llc
