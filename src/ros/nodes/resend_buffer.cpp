#include "laser_loop_closure/ros/nodes/resend_buffer.hpp"

namespace llc_ros {

void ResendBuffer::keyframe(const laser_loop_closure::Keyframe& msg) {
  Sent sent;
  sent.keyframe = msg;
  add(std::move(sent));
}

void ResendBuffer::keyframe(const laser_loop_closure::PackedKeyframe& msg) {
  Sent sent;
  sent.packed = true;
  sent.packed_keyframe = msg;
  add(std::move(sent));
}

void ResendBuffer::add(Sent sent) {
  if (capacity_ == 0) return;
  std::lock_guard<std::mutex> lock(mutex_);
  sent_.push_back(std::move(sent));
  while (sent_.size() > capacity_) sent_.pop_front();
}

void ResendBuffer::loop(const laser_loop_closure::LoopClosure& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!sent_.empty()) sent_.back().loops.push_back(msg);
}

std::size_t ResendBuffer::sendFrom(std::size_t first,
                                   const std::function<void(const laser_loop_closure::Keyframe&)>& send_keyframe,
                                   const std::function<void(const laser_loop_closure::PackedKeyframe&)>& send_packed,
                                   const std::function<void(const laser_loop_closure::LoopClosure&)>& send_loop,
                                   std::size_t* gone) const {
  std::vector<Sent> copy;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // copied out: sending may take a while
    for (const Sent& sent : sent_)
      if (sent.index() >= first) copy.push_back(sent);
    if (gone) {
      const std::size_t oldest = sent_.empty() ? first : sent_.front().index();
      *gone = oldest > first ? oldest - first : 0;
    }
  }
  for (const Sent& sent : copy) {
    if (sent.packed) send_packed(sent.packed_keyframe);
    else send_keyframe(sent.keyframe);
    for (const laser_loop_closure::LoopClosure& loop : sent.loops) send_loop(loop);
  }
  return copy.size();
}

std::size_t ResendBuffer::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sent_.size();
}

}  // namespace llc_ros
