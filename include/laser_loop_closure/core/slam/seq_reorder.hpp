// Scans put back in the order their driver numbered them (a ROS header's seq), for a front end
// without wheel odometry: there the scans before a scan predict it, so the order they were
// taken in is the motion's only clock. (With wheels each scan is seeded by their reading at its
// own stamp, whatever the order.) A stream always in order passes straight through, as does one
// with gaps (a dropped message) or no numbering (every seq the same). Only once a scan arrived
// after one numbered higher (the Intel bag: sorted by stamps its log wrote after the scans were
// taken, 670 scans out of place by up to 14) are scans held while one numbered lower is missing,
// at most `scans` of them: then the gap is given up. A scan that comes after its place was
// given up or passed (by up to twice `scans`) is skipped (counted), not handed out of order; a
// jump further back or ahead is a new numbering.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace llc {

struct SeqReorderOptions {
  /// Scans held at most while one numbered lower is missing (half a second of a 40 Hz
  /// scanner); 0: off (every scan handed out as it comes).
  int scans = 20;
  [[nodiscard]] std::string validate() const { return scans >= 0 ? "" : "seq_reorder_scans must be 0 (off) or more"; }
};

struct SeqReorderCounters {
  std::size_t reordered = 0;    ///< scans that came early and were held until the ones before them came
  std::size_t late_skipped = 0; ///< scans that came after their place was passed: skipped
  std::size_t gaps_given_up = 0;///< missing numbers given up (held scans beyond `scans`)
  std::size_t restarts = 0;     ///< numbering that jumped back by more than twice `scans` (a looped bag, a restarted driver)
  bool out_of_order_seen = false;  ///< a scan came after one numbered higher: holding from then on
};

template <class Item>
class SeqReorder {
 public:
  explicit SeqReorder(SeqReorderOptions options = {}) : window_(options.scans > 0 ? std::size_t(options.scans) : 0) {}

  /// Takes the scan numbered `seq`; appends to *out the scans now due, in their numbers' order.
  void push(std::uint32_t seq, Item item, std::vector<Item>* out) {
    if (window_ == 0 || !started_) {
      started_ = true;
      last_ = seq;
      out->push_back(std::move(item));
      return;
    }
    // Numbers differ by less than 2^31 in any real stream: the difference survives wrapping.
    const std::int64_t ahead = std::int32_t(seq - std::uint32_t(last_));
    const std::int64_t number = last_ + ahead;
    if (ahead == 0) {  // no numbering (every seq the same) or a repeat: as it comes
      out->push_back(std::move(item));
      return;
    }
    // Within twice the window: a scan late, even after its gap was given up.
    if (ahead < 0 && -ahead <= 2 * std::int64_t(window_)) {  // its place has passed
      counters_.out_of_order_seen = true;
      ++counters_.late_skipped;
      return;
    }
    if (ahead < 0 || ahead > 2 * std::int64_t(window_)) {  // a new numbering, or a jump beyond any hold
      counters_.restarts += ahead < 0;
      flush(out);
      last_ = number;
      out->push_back(std::move(item));
      return;
    }
    if (ahead == 1 || !counters_.out_of_order_seen) {  // next in line, or a gap in a stream never out of order
      last_ = number;
      out->push_back(std::move(item));
      releaseInLine(out);
      return;
    }
    if (!held_.emplace(number, std::move(item)).second) return;  // held already: a repeat
    if (held_.size() > window_) {  // the missing ones are given up
      counters_.gaps_given_up += std::size_t(held_.begin()->first - last_ - 1);
      releaseFirst(out);
      releaseInLine(out);
    }
  }

  /// Every held scan, in order (the end of a bag; a live stream that paused).
  void flush(std::vector<Item>* out) {
    while (!held_.empty()) releaseFirst(out);
  }

  std::size_t held() const { return held_.size(); }
  const SeqReorderCounters& counters() const { return counters_; }

 private:
  void releaseFirst(std::vector<Item>* out) {
    auto first = held_.begin();
    last_ = first->first;
    ++counters_.reordered;
    out->push_back(std::move(first->second));
    held_.erase(first);
  }
  void releaseInLine(std::vector<Item>* out) {
    while (!held_.empty() && held_.begin()->first == last_ + 1) releaseFirst(out);
  }

  std::size_t window_;
  bool started_ = false;
  std::int64_t last_ = 0;  ///< the number of the last scan handed out, unwrapped
  std::map<std::int64_t, Item> held_;
  SeqReorderCounters counters_;
};

}  // namespace llc
