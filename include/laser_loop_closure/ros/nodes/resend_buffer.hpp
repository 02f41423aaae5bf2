// The newest keyframes a front end sent, each with the loops sent after it, kept to be sent
// again when a back end across a network missed some (its resend_request names the first one
// it lacks). Bounded: the oldest go first. Thread-safe (the worker records, a callback resends).
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <vector>

#include "laser_loop_closure/Keyframe.h"
#include "laser_loop_closure/PackedKeyframe.h"
#include "laser_loop_closure/LoopClosure.h"

namespace llc_ros {

class ResendBuffer {
 public:
  explicit ResendBuffer(std::size_t capacity) : capacity_(capacity) {}
  /// A keyframe as it was sent (capacity 0: nothing is kept).
  void keyframe(const laser_loop_closure::Keyframe& msg);
  void keyframe(const laser_loop_closure::PackedKeyframe& msg);
  /// A loop as it was sent: it belongs to the newest keyframe sent (loops come after theirs).
  void loop(const laser_loop_closure::LoopClosure& msg);
  /// Sends again every kept keyframe numbered `first` or later, each followed by its loops, in
  /// the order they went. Returns how many keyframes it sent; *gone (when given) counts those
  /// from `first` on that are no longer kept.
  std::size_t sendFrom(std::size_t first, const std::function<void(const laser_loop_closure::Keyframe&)>& send_keyframe,
                       const std::function<void(const laser_loop_closure::PackedKeyframe&)>& send_packed,
                       const std::function<void(const laser_loop_closure::LoopClosure&)>& send_loop,
                       std::size_t* gone = nullptr) const;
  std::size_t size() const;

 private:
  struct Sent {
    bool packed = false;  ///< sent as packed_keyframe, else as keyframe
    laser_loop_closure::Keyframe keyframe;
    laser_loop_closure::PackedKeyframe packed_keyframe;
    std::vector<laser_loop_closure::LoopClosure> loops;
    std::uint32_t index() const { return packed ? packed_keyframe.index : keyframe.index; }
  };
  void add(Sent sent);
  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::deque<Sent> sent_;
};

}  // namespace llc_ros
