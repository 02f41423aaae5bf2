// A restored session put back together from its parts, and every way the parts can go wrong.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"
#include "laser_loop_closure/ros/io/session_parts.hpp"

namespace {

using llc_ros::SessionAssembler;

/// A session of n keyframes in parts of `per_part`, as the back end's ~load_session sends it.
std::vector<laser_loop_closure::Session> sessionParts(std::size_t n, std::size_t per_part, std::uint32_t load) {
  const std::size_t parts = std::max<std::size_t>(1, (n + per_part - 1) / per_part);
  std::vector<laser_loop_closure::Session> out;
  for (std::size_t p = 0; p < parts; ++p) {
    laser_loop_closure::Session msg;
    msg.load = load, msg.part = std::uint32_t(p), msg.parts = std::uint32_t(parts);
    msg.first_keyframe = std::uint32_t(p * per_part), msg.total_keyframes = std::uint32_t(n);
    for (std::size_t k = p * per_part; k < std::min(n, (p + 1) * per_part); ++k) {
      llc::Keyframe keyframe;
      keyframe.scan_index = k, keyframe.stamp = double(k);
      // (Vectors built, not brace lists assigned: that trips GCC 12's -Wnonnull false positive.)
      keyframe.scan.ranges = std::vector<double>{1.0, 2.0, 3.0}, keyframe.scan.bearings = std::vector<double>{-1.0, 0.0, 1.0};
      keyframe.scan.stamp = double(k);
      msg.keyframes.push_back(llc_ros::toKeyframeMsg(keyframe, k, llc::OdometryStep{}, ""));
      msg.keyframes.back().features = std::vector<double>{double(k), 0.5};
    }
    out.push_back(msg);
  }
  return out;
}

TEST(SessionParts, InOrderTheyGiveTheWholeSessionOnceTheLastCame) {
  SessionAssembler assembler;
  const auto parts = sessionParts(250, 100, 1);
  ASSERT_EQ(parts.size(), 3u);
  llc_ros::AssembledSession session;
  std::string error;
  EXPECT_EQ(assembler.add(parts[0], &session, &error), SessionAssembler::Status::kIncomplete);
  EXPECT_EQ(assembler.add(parts[1], &session, &error), SessionAssembler::Status::kIncomplete);
  ASSERT_EQ(assembler.add(parts[2], &session, &error), SessionAssembler::Status::kComplete) << error;
  ASSERT_EQ(session.keyframes.size(), 250u);
  ASSERT_EQ(session.features.size(), 250u);
  for (std::size_t k = 0; k < 250; ++k) {
    EXPECT_EQ(session.keyframes[k].scan_index, k);
    EXPECT_EQ(session.features[k].front(), double(k));
  }
  // A session of one part, and an empty one.
  EXPECT_EQ(assembler.add(sessionParts(5, 100, 2)[0], &session, &error), SessionAssembler::Status::kComplete) << error;
  EXPECT_EQ(session.keyframes.size(), 5u);
  EXPECT_EQ(assembler.add(sessionParts(0, 100, 3)[0], &session, &error), SessionAssembler::Status::kComplete) << error;
  EXPECT_TRUE(session.keyframes.empty());
}

TEST(SessionParts, AMissingPartAnInterruptedLoadOrABadKeyframeRefusesThatLoad) {
  llc_ros::AssembledSession session;
  std::string error;
  {  // part 1 lost
    SessionAssembler assembler;
    const auto parts = sessionParts(250, 100, 1);
    assembler.add(parts[0], &session, &error);
    EXPECT_EQ(assembler.add(parts[2], &session, &error), SessionAssembler::Status::kRefused);
    EXPECT_NE(error.find("came without the parts before it"), std::string::npos) << error;
  }
  {  // a second load starts before the first ended: the first is dropped, the second restores
    SessionAssembler assembler;
    const auto first = sessionParts(250, 100, 1), second = sessionParts(150, 100, 2);
    assembler.add(first[0], &session, &error);
    EXPECT_EQ(assembler.add(second[0], &session, &error), SessionAssembler::Status::kIncomplete);
    EXPECT_EQ(assembler.add(first[1], &session, &error), SessionAssembler::Status::kRefused);
    EXPECT_EQ(assembler.add(second[0], &session, &error), SessionAssembler::Status::kIncomplete);
    ASSERT_EQ(assembler.add(second[1], &session, &error), SessionAssembler::Status::kComplete) << error;
    EXPECT_EQ(session.keyframes.size(), 150u);
  }
  {  // a keyframe whose ranges and bearings differ in length
    SessionAssembler assembler;
    auto parts = sessionParts(150, 100, 1);
    parts[1].keyframes[3].scan.ranges.pop_back();
    assembler.add(parts[0], &session, &error);
    EXPECT_EQ(assembler.add(parts[1], &session, &error), SessionAssembler::Status::kRefused);
    EXPECT_NE(error.find("keyframe 103"), std::string::npos) << error;
  }
  {  // fewer keyframes than the session says it has
    SessionAssembler assembler;
    auto parts = sessionParts(150, 100, 1);
    parts[1].total_keyframes = 160;
    assembler.add(parts[0], &session, &error);
    EXPECT_EQ(assembler.add(parts[1], &session, &error), SessionAssembler::Status::kRefused);
    EXPECT_NE(error.find("150 keyframes came, the session has 160"), std::string::npos) << error;
  }
}

}  // namespace
