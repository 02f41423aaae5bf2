// Wall time spent inside a subscriber callback, told in the diagnostics: the figure that shows
// whether a callback ever waits for map building, optimisation or serialisation (it must not:
// those run on their own threads). Thread-safe; measure() returns a scope that records on exit.
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>

#include <algorithm>
#include <chrono>
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
    std::lock_guard<std::mutex> lock(mutex_);
    ++count_;
    total_ += seconds;
    longest_ = std::max(longest_, seconds);
  }

  /// Adds "<what>: calls", "<what>: longest (ms)" and "<what>: mean (ms)".
  void addTo(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& what) const {
    std::lock_guard<std::mutex> lock(mutex_);
    status.add(what + ": calls", count_);
    status.add(what + ": longest (ms)", 1e3 * longest_);
    status.add(what + ": mean (ms)", count_ > 0 ? 1e3 * total_ / double(count_) : 0.0);
  }

 private:
  mutable std::mutex mutex_;
  std::size_t count_ = 0;
  double total_ = 0.0, longest_ = 0.0;
};

}  // namespace llc_ros
