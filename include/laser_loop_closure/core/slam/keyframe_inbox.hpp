// One robot's keyframes as a back end across a network meets them (the multi-robot back end):
// numbered by the robot's own front end, they may come out of order, twice (sent again), with
// numbers missing (lost on the way), or numbered from 0 again (the front end restarted). The
// inbox holds them and hands them out in number order, each once: a keyframe waits for the
// loops sent before it (loops_before, as llc slam takes them), and for missing ones asked again
// (resend_wait), after which the gap is bridged. It maps the front end's numbers to the order
// keyframes were taken in (the robot's pipeline indices). Header-only: Payload is whatever the
// caller carries (a message pointer). Bounded: a number absurdly far ahead is refused.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace llc {

struct KeyframeInboxOptions {
  double resend_wait = 10.0;   ///< s a keyframe after a gap waits for the missing ones before the gap is bridged
  double resend_every = 2.0;   ///< s between two asks for the same missing keyframes
  std::size_t max_held = 1000;  ///< keyframes held at most; beyond, the first is taken (its gap bridged)
  std::size_t max_gap = 100000;  ///< a keyframe numbered further past the next expected one is refused (a corrupt number)
  std::size_t most_held_for_loops = 3;  ///< keyframes held behind one whose loops never come, before it is taken anyway
  [[nodiscard]] std::string validate() const {
    if (!(resend_wait >= 0.0) || !(resend_every > 0.0)) return "resend_wait >= 0 and resend_every > 0";
    if (max_held == 0 || max_gap == 0) return "max_held and max_gap must be >= 1";
    return "";
  }
};

template <class Payload>
class KeyframeInbox {
 public:
  enum class Offer { kHeld, kAgain, kRefused };
  /// A keyframe handed out: take it now, in this order.
  struct Taken {
    Payload payload;
    std::uint32_t number = 0;
    std::size_t lost_before = 0;  ///< numbers that never came just before it (a gap bridged)
    bool restarted = false;       ///< the first of a new run: its front end numbered from 0 again
  };
  struct Counters {
    std::size_t taken = 0, lost = 0, again = 0, refused = 0, restarts = 0, loops_again = 0;
  };

  explicit KeyframeInbox(const KeyframeInboxOptions& options = {}) : options_(options) {}

  /// A keyframe came (its front end's number, the loops it sent before it, its stamp). Held;
  /// or kAgain: taken or held already (sent again), ignored; or kRefused (*why says why).
  Offer offer(std::uint32_t number, std::uint64_t loops_before, double stamp, Payload payload, std::string* why = nullptr) {
    if (number < run_.numbers.size() || isHeld(held_, number)) {
      // Numbered before: sent again, unless newer than anything of this run (a new run).
      if (!(stamp > newest_stamp_)) {
        ++counters_.again;
        return Offer::kAgain;
      }
      if (isHeld(next_run_, number)) {
        ++counters_.again;
        return Offer::kAgain;
      }
      insert(next_run_, {number, loops_before, stamp, std::move(payload)});
      return Offer::kHeld;
    }
    if (!next_run_.empty()) {  // a new run began: what comes now is its
      if (isHeld(next_run_, number)) {
        ++counters_.again;
        return Offer::kAgain;
      }
      insert(next_run_, {number, loops_before, stamp, std::move(payload)});
      return Offer::kHeld;
    }
    if (number - run_.numbers.size() > options_.max_gap) {
      ++counters_.refused;
      if (why) *why = "keyframe " + std::to_string(number) + " is more than " + std::to_string(options_.max_gap) +
                      " past the next expected (" + std::to_string(run_.numbers.size()) + ")";
      return Offer::kRefused;
    }
    newest_stamp_ = std::max(newest_stamp_, stamp);
    insert(held_, {number, loops_before, stamp, std::move(payload)});
    return Offer::kHeld;
  }

  /// A loop (from, to: the front end's numbers) came; false when it came before in this run.
  bool loopArrived(std::uint32_t from, std::uint32_t to) {
    if (!run_.loops_seen.insert({from, to}).second) {
      ++counters_.loops_again;
      return false;
    }
    ++run_.loops_taken;
    return true;
  }

  /// The next keyframe to take at time `now` (s, any steady clock), or none (waiting). When it
  /// waits for missing keyframes that should be asked for now, *ask_from is the first missing number.
  std::optional<Taken> next(double now, std::optional<std::uint32_t>* ask_from = nullptr) {
    if (ask_from) ask_from->reset();
    if (held_.empty()) {
      if (next_run_.empty()) return std::nullopt;
      startNewRun();
    }
    const bool flushing = !next_run_.empty();  // a new run waits: the old one's are taken at once
    Held& first = held_.front();
    const std::size_t expected = run_.numbers.size();
    std::size_t lost = 0;
    if (first.number > expected && (expected > 0 || run_.started)) {  // a gap (not the run's first keyframe here)
      if (gap_since_ < 0.0) gap_since_ = now;
      const bool give_up = flushing || now - gap_since_ >= options_.resend_wait || held_.size() >= options_.max_held;
      if (!give_up) {
        if (ask_from && (last_ask_ < 0.0 || now - last_ask_ >= options_.resend_every)) {
          *ask_from = std::uint32_t(expected);
          last_ask_ = now;
        }
        return std::nullopt;
      }
      lost = first.number - expected;
    }
    if (!flushing && first.loops_before > run_.loops_taken) {
      if (held_.size() <= options_.most_held_for_loops) return std::nullopt;
      run_.loops_taken = first.loops_before;  // its loops were lost (or came before this inbox did)
    }
    gap_since_ = -1.0;  // progress: a gap after it waits anew (what was asked is on its way: not asked again yet)
    Taken taken{std::move(first.payload), first.number, lost, run_.restart};
    run_.restart = false;
    run_.started = true;
    run_.numbers.resize(first.number, -1);
    run_.numbers.push_back(long(counters_.taken));
    front_numbers_.push_back(first.number);
    counters_.lost += lost;
    ++counters_.taken;
    held_.pop_front();
    return taken;
  }

  /// The take-order index (the pipeline's) of keyframe `number` of the current run; -1 when it
  /// never came (lost) or has not been taken yet.
  long pipelineIndex(std::uint32_t number) const {
    return number < run_.numbers.size() ? run_.numbers[number] : -1;
  }
  /// Whether keyframe `number` of the current run is settled: taken, or lost for good.
  bool settled(std::uint32_t number) const { return number < run_.numbers.size(); }
  /// The front end's number of the pipeline's keyframe `index` when it is of the current run.
  std::optional<std::uint32_t> frontNumber(std::size_t index) const {
    if (index < run_.first_index || index >= front_numbers_.size()) return std::nullopt;
    return front_numbers_[index];
  }
  /// The pipeline keyframes of the current run numbered below `number` (a NearbyKeyframes `before`).
  std::size_t pipelineCountBelow(std::uint32_t number) const {
    const auto begin = front_numbers_.begin() + long(run_.first_index);
    return std::size_t(std::lower_bound(begin, front_numbers_.end(), number) - front_numbers_.begin());
  }
  /// Keyframes of the current run settled (the next number expected) and loop messages taken.
  std::size_t expected() const { return run_.numbers.size(); }
  std::uint64_t loopsTaken() const { return run_.loops_taken; }
  std::size_t held() const { return held_.size() + next_run_.size(); }
  const Counters& counters() const { return counters_; }
  const KeyframeInboxOptions& options() const { return options_; }

 private:
  struct Held {
    std::uint32_t number;
    std::uint64_t loops_before;
    double stamp;
    Payload payload;
  };
  /// One run of the front end (from its keyframe 0): reset as one when it starts again.
  struct Run {
    std::vector<long> numbers;  ///< per front-end number: its take index, -1 when lost
    std::set<std::pair<std::uint32_t, std::uint32_t>> loops_seen;
    std::uint64_t loops_taken = 0;
    std::size_t first_index = 0;  ///< take index of its first keyframe
    bool restart = false;         ///< its first keyframe starts a new run
    bool started = false;         ///< it has taken a keyframe
  };

  static bool isHeld(const std::deque<Held>& queue, std::uint32_t number) {
    return std::any_of(queue.begin(), queue.end(), [number](const Held& h) { return h.number == number; });
  }
  static void insert(std::deque<Held>& queue, Held held) {
    const auto at = std::lower_bound(queue.begin(), queue.end(), held.number,
                                     [](const Held& h, std::uint32_t n) { return h.number < n; });
    queue.insert(at, std::move(held));
  }
  void startNewRun() {
    run_ = Run{};
    run_.first_index = counters_.taken;
    run_.restart = true;
    held_.swap(next_run_);
    newest_stamp_ = held_.back().stamp;
    for (const Held& h : held_) newest_stamp_ = std::max(newest_stamp_, h.stamp);
    gap_since_ = -1.0;
    last_ask_ = -1.0;
    ++counters_.restarts;
  }

  KeyframeInboxOptions options_;
  std::deque<Held> held_;      ///< this run's, by number
  std::deque<Held> next_run_;  ///< a new run's, by number, until this run's are taken
  Run run_;
  std::vector<std::uint32_t> front_numbers_;  ///< per take index: the front end's number (its run's)
  double newest_stamp_ = -1e300;
  double gap_since_ = -1.0, last_ask_ = -1.0;
  Counters counters_;
};

}  // namespace llc
