// ResendBuffer: the keyframes a front end sent, each with its loops, sent again from a number on,
// in the order they went; bounded, the oldest going first.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "laser_loop_closure/ros/nodes/resend_buffer.hpp"

namespace {

laser_loop_closure::Keyframe keyframe(std::uint32_t index) {
  laser_loop_closure::Keyframe k;
  k.index = index;
  return k;
}

laser_loop_closure::LoopClosure loop(std::uint32_t from, std::uint32_t to) {
  laser_loop_closure::LoopClosure l;
  l.from_keyframe = from;
  l.to_keyframe = to;
  return l;
}

laser_loop_closure::PackedKeyframe packedKeyframe(std::uint32_t index) {
  laser_loop_closure::PackedKeyframe k;
  k.index = index;
  return k;
}

/// What sendFrom(first) sends, as "k5 l1-5 p6" (k: a Keyframe, p: a PackedKeyframe).
std::string sent(const llc_ros::ResendBuffer& buffer, std::size_t first, std::size_t* gone = nullptr) {
  std::string out;
  buffer.sendFrom(
      first, [&](const laser_loop_closure::Keyframe& k) { out += (out.empty() ? "k" : " k") + std::to_string(k.index); },
      [&](const laser_loop_closure::PackedKeyframe& k) { out += (out.empty() ? "p" : " p") + std::to_string(k.index); },
      [&](const laser_loop_closure::LoopClosure& l) {
        out += " l" + std::to_string(l.from_keyframe) + "-" + std::to_string(l.to_keyframe);
      },
      gone);
  return out;
}

TEST(ResendBuffer, SendsKeyframesWithTheirLoopsInTheOrderTheyWent) {
  llc_ros::ResendBuffer buffer(3);
  buffer.loop(loop(0, 0));  // before any keyframe: belongs to none, dropped
  for (std::uint32_t k = 0; k < 5; ++k) {
    buffer.keyframe(keyframe(k));
    if (k % 2 == 1) buffer.loop(loop(0, k)), buffer.loop(loop(k - 1, k));
  }
  EXPECT_EQ(buffer.size(), 3u);  // 2, 3, 4 kept
  std::size_t gone = 0;
  EXPECT_EQ(sent(buffer, 3, &gone), "k3 l0-3 l2-3 k4");
  EXPECT_EQ(gone, 0u);
  EXPECT_EQ(sent(buffer, 0, &gone), "k2 k3 l0-3 l2-3 k4");
  EXPECT_EQ(gone, 2u);  // 0 and 1 no longer kept
  EXPECT_EQ(sent(buffer, 9, &gone), "");
}

TEST(ResendBuffer, SendsEachKeyframeAgainAsItWent) {
  // A front end that packs sends a keyframe unpacked when packing failed: each goes again as it went.
  llc_ros::ResendBuffer buffer(4);
  buffer.keyframe(packedKeyframe(0));
  buffer.keyframe(keyframe(1));
  buffer.loop(loop(0, 1));
  buffer.keyframe(packedKeyframe(2));
  EXPECT_EQ(sent(buffer, 0), "p0 k1 l0-1 p2");
  EXPECT_EQ(sent(buffer, 2), "p2");
}

TEST(ResendBuffer, CapacityZeroKeepsNothing) {
  llc_ros::ResendBuffer buffer(0);
  buffer.keyframe(keyframe(0));
  buffer.loop(loop(0, 0));
  EXPECT_EQ(buffer.size(), 0u);
  EXPECT_EQ(sent(buffer, 0), "");
}

}  // namespace
