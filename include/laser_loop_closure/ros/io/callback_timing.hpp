// Wall time spent inside a subscriber callback, told in the diagnostics: the figure that shows
// whether a callback ever waits for map building, optimisation or serialisation (it must not:
// those run on their own threads), and how its latency is spread (median, 99th percentile).
// Thread-safe; measure() returns a scope that records on exit; constant memory (a histogram of
// 10% wide bins from 1 us to 100 s).
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <mutex>
#include <string>

namespace llc_ros {

class CallbackTiming {
 public:
  class Scope {
   public:
    explicit Scope(CallbackTiming& timing) : timing_(timing), start_(std::chrono::steady_clock::now()) {}
    ~Scope() { timing_.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count()); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    CallbackTiming& timing_;
    std::chrono::steady_clock::time_point start_;
  };

  /// Times the enclosing block: `const auto timed = timing.measure();`.
  Scope measure() { return Scope(*this); }

  void record(double seconds) {
    if (!std::isfinite(seconds)) return;  // (a clock gives none; one would spoil the mean for good)
    std::lock_guard<std::mutex> lock(mutex_);
    ++count_;
    total_ += seconds;
    longest_ = std::max(longest_, seconds);
    ++bins_[binOf(seconds)];
  }

  /// The latency below which `share` (0..1) of the calls stayed: the upper edge of its bin
  /// (at most 10% above the true value; never above the longest). 0 before any call.
  double quantile(double share) const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count_ == 0) return 0.0;
    const double wanted = std::clamp(share, 0.0, 1.0) * double(count_);
    std::size_t seen = 0;
    for (std::size_t bin = 0; bin < kBins; ++bin) {
      seen += bins_[bin];
      if (seen == 0 || double(seen) < wanted) continue;
      return bin + 1 == kBins ? longest_ : std::min(longest_, kFirstEdge * std::pow(kRatio, double(bin)));
    }
    return longest_;
  }

  /// Adds "<what>: calls", "<what>: longest (ms)", "<what>: mean (ms)", "<what>: median (ms)"
  /// and "<what>: p99 (ms)" (the last two to 10%).
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& what) const {
    const double median = quantile(0.5), p99 = quantile(0.99);
    std::lock_guard<std::mutex> lock(mutex_);
    status.add(what + ": calls", count_);
    status.add(what + ": longest (ms)", 1e3 * longest_);
    status.add(what + ": mean (ms)", count_ > 0 ? 1e3 * total_ / double(count_) : 0.0);
    status.add(what + ": median (ms)", 1e3 * median);
    status.add(what + ": p99 (ms)", 1e3 * p99);
  }

 private:
  static constexpr double kFirstEdge = 1e-6;  ///< s; bin 0 holds everything up to it
  static constexpr double kRatio = 1.1;       ///< each bin's upper edge over the one before
  static constexpr std::size_t kBins = 195;   ///< 1e-6 x 1.1^194 > 100 s: the last bin holds the rest
  static std::size_t binOf(double seconds) {
    if (!(seconds > kFirstEdge)) return 0;
    const double bin = std::ceil(std::log(seconds / kFirstEdge) / std::log(kRatio));
    return std::size_t(std::min(bin, double(kBins - 1)));
  }

  mutable std::mutex mutex_;
  std::size_t count_ = 0;
  double total_ = 0.0, longest_ = 0.0;
  std::array<std::size_t, kBins> bins_{};
};

}  // namespace llc_ros
