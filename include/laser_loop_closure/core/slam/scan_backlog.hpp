// The scans waiting for a live front end's worker thread: a bounded first-in-first-out queue
// that never makes its producer wait (a full queue is thinned where its scans lie closest in
// time) and lets a consumer
// that fell behind catch up by skipping old scans. It measures the lag in scan time (the newest
// scan's stamp minus the stamp of the scan handed out), so it works on a clock that stopped.
#pragma once

#include <algorithm>
#include <condition_variable>
#include <functional>
#include <cstddef>
#include <deque>
#include <mutex>
#include <string>
#include <utility>

namespace llc {

struct ScanBacklogOptions {
  std::size_t capacity = 200;  ///< scans kept waiting; a push beyond thins the queue
  /// s of scan time the consumer may fall behind the newest scan before the oldest waiting
  /// scans are skipped (the newest waiting one is always kept); <= 0: never skip for lag.
  double max_lag = 5.0;
  [[nodiscard]] std::string validate() const {
    if (capacity < 1) return "capacity must be at least 1";
    return "";
  }
};

/// What the backlog did since it was made.
struct ScanBacklogCounters {
  std::size_t pushed = 0, popped = 0;
  std::size_t dropped_full = 0;    ///< scans dropped because the queue was full (thinned)
  std::size_t dropped_behind = 0;  ///< old scans skipped because the consumer was more than max_lag behind
  std::size_t waiting = 0;         ///< scans in the queue now
  double lag = 0.0;                ///< s of scan time behind the newest scan, at the last pop
  double largest_lag = 0.0;        ///< s; the largest lag at a pop (after skipping)
};

template <class Item>
class ScanBacklog {
 public:
  explicit ScanBacklog(ScanBacklogOptions options) : options_(options) {}

  /// Adds a scan stamped `stamp` (s). Returns how many scans were dropped to make room (0 or 1).
  /// A full queue is thinned, not cut at its front: the scan that goes is the one whose
  /// neighbours lie closest in time (never the oldest nor the newest), so the scans still
  /// handed out stay spread evenly over the time the consumer was busy, and an odometry chain
  /// made of them meets gaps of a few scans, not one gap of a whole queue (a front end without
  /// wheels cannot match across that and loses its way).
  std::size_t push(Item item, double stamp) {
    std::size_t dropped = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (queue_.size() >= options_.capacity) {
        std::size_t drop = 0;  // one or two scans: the oldest
        double narrowest = 0.0;
        for (std::size_t i = 1; i + 1 < queue_.size(); ++i) {
          const double span = queue_[i + 1].second - queue_[i - 1].second;
          if (drop == 0 || span < narrowest) drop = i, narrowest = span;
        }
        queue_.erase(queue_.begin() + long(drop));
        ++counters_.dropped_full;
        dropped = 1;
      }
      queue_.emplace_back(std::move(item), stamp);
      newest_stamp_ = stamp;  // the last pushed, even when stamps went back (a bag looped)
      ++counters_.pushed;
    }
    ready_.notify_one();
    return dropped;
  }

  /// Work for the consumer between two scans, in the order posted, before any scan waiting and
  /// never dropped: what another thread wants done to what only the consumer touches (a
  /// session to restore, a model to swap in), so that no one else needs a lock on it.
  void post(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tasks_.push_back(std::move(task));
    }
    ready_.notify_one();
  }

  /// Waits for a scan (or stop()), running the tasks posted meanwhile first (on this thread,
  /// outside the queue's lock). When the oldest waiting scan is more than max_lag behind the
  /// newest, it is skipped while newer ones wait. False once stopped (tasks still waiting are
  /// dropped: whoever waits on one must not outlive the consumer).
  bool pop(Item* item) {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      ready_.wait(lock, [this] { return stopped_ || !queue_.empty() || !tasks_.empty(); });
      if (stopped_) return false;
      if (tasks_.empty()) break;
      std::function<void()> task = std::move(tasks_.front());
      tasks_.pop_front();
      lock.unlock();
      task();
      lock.lock();
    }
    while (options_.max_lag > 0.0 && queue_.size() > 1 && newest_stamp_ - queue_.front().second > options_.max_lag) {
      queue_.pop_front();
      ++counters_.dropped_behind;
    }
    *item = std::move(queue_.front().first);
    counters_.lag = std::max(0.0, newest_stamp_ - queue_.front().second);
    counters_.largest_lag = std::max(counters_.largest_lag, counters_.lag);
    queue_.pop_front();
    ++counters_.popped;
    return true;
  }

  /// Wakes every pop() for good: they return false.
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    ready_.notify_all();
  }

  ScanBacklogCounters counters() const {
    std::lock_guard<std::mutex> lock(mutex_);
    ScanBacklogCounters c = counters_;
    c.waiting = queue_.size();
    return c;
  }

 private:
  ScanBacklogOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::pair<Item, double>> queue_;
  std::deque<std::function<void()>> tasks_;
  double newest_stamp_ = 0.0;
  bool stopped_ = false;
  ScanBacklogCounters counters_;
};

}  // namespace llc
