// KeyframeInbox: one robot's keyframes over a network, handed out in number order and once,
// after their loops, with missing ones asked for again, gaps bridged after resend_wait, a
// restarted front end taken as a new run, and corrupt numbers refused.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/keyframe_inbox.hpp"

namespace {

using Inbox = llc::KeyframeInbox<int>;  // the payload: the keyframe's number again

/// Every keyframe the inbox hands out at time `now`, as numbers.
std::vector<std::uint32_t> drain(Inbox& inbox, double now, std::optional<std::uint32_t>* ask = nullptr) {
  std::vector<std::uint32_t> taken;
  while (auto t = inbox.next(now, ask)) {
    EXPECT_EQ(std::uint32_t(t->payload), t->number);
    taken.push_back(t->number);
  }
  return taken;
}

TEST(KeyframeInbox, HandsKeyframesOutInOrderOnceAfterTheirLoops) {
  Inbox inbox;
  EXPECT_EQ(inbox.offer(2, 0, 2.0, 2), Inbox::Offer::kHeld);
  EXPECT_EQ(inbox.offer(0, 0, 0.0, 0), Inbox::Offer::kHeld);
  EXPECT_EQ(drain(inbox, 0.0), (std::vector<std::uint32_t>{0}));  // 2 waits for 1
  EXPECT_EQ(inbox.offer(1, 2, 1.0, 1), Inbox::Offer::kHeld);      // sent after two loops
  EXPECT_TRUE(drain(inbox, 0.0).empty());                          // which have not come
  EXPECT_TRUE(inbox.loopArrived(0, 0));
  EXPECT_FALSE(inbox.loopArrived(0, 0));  // the same loop again: not counted
  EXPECT_TRUE(drain(inbox, 0.0).empty());
  EXPECT_TRUE(inbox.loopArrived(0, 1));
  EXPECT_EQ(drain(inbox, 0.0), (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(inbox.offer(1, 2, 1.0, 1), Inbox::Offer::kAgain);  // sent again: ignored
  EXPECT_TRUE(drain(inbox, 0.0).empty());
  EXPECT_EQ(inbox.pipelineIndex(2), 2);
  EXPECT_EQ(inbox.pipelineIndex(3), -1);
  EXPECT_EQ(inbox.counters().again, 1u);
  EXPECT_EQ(inbox.counters().loops_again, 1u);
}

TEST(KeyframeInbox, MissingKeyframesAreAskedForThenTheGapIsBridged) {
  llc::KeyframeInboxOptions options;
  options.resend_wait = 10.0;
  options.resend_every = 2.0;
  Inbox inbox(options);
  inbox.offer(0, 0, 0.0, 0);
  inbox.offer(1, 0, 1.0, 1);
  EXPECT_EQ(drain(inbox, 0.0).size(), 2u);
  inbox.offer(4, 0, 4.0, 4);  // 2 and 3 lost on the way
  std::optional<std::uint32_t> ask;
  EXPECT_TRUE(drain(inbox, 100.0, &ask).empty());
  ASSERT_TRUE(ask);
  EXPECT_EQ(*ask, 2u);
  EXPECT_TRUE(drain(inbox, 101.0, &ask).empty());
  EXPECT_FALSE(ask);  // asked a second ago
  EXPECT_TRUE(drain(inbox, 102.5, &ask).empty());
  EXPECT_TRUE(ask);  // asked again
  // Sent again, one by one: each taken as it comes, and the rest, on their way, not asked again.
  inbox.offer(2, 0, 2.0, 2);
  EXPECT_EQ(drain(inbox, 103.0, &ask), (std::vector<std::uint32_t>{2}));
  EXPECT_FALSE(ask);
  inbox.offer(3, 0, 3.0, 3);
  EXPECT_EQ(drain(inbox, 103.1, &ask), (std::vector<std::uint32_t>{3, 4}));
  EXPECT_EQ(inbox.counters().lost, 0u);

  // Never sent again: after resend_wait the gap is bridged and counted.
  inbox.offer(7, 0, 7.0, 7);
  EXPECT_TRUE(drain(inbox, 200.0).empty());
  auto taken = inbox.next(210.0);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->number, 7u);
  EXPECT_EQ(taken->lost_before, 2u);
  EXPECT_EQ(inbox.pipelineIndex(5), -1);
  EXPECT_EQ(inbox.pipelineIndex(7), 5);
  EXPECT_TRUE(inbox.settled(6));
  EXPECT_EQ(inbox.counters().lost, 2u);
  EXPECT_EQ(inbox.offer(5, 0, 5.0, 5), Inbox::Offer::kAgain);  // too late: lost for good
}

TEST(KeyframeInbox, HeldIsBoundedAndLostLoopsDoNotStallIt) {
  llc::KeyframeInboxOptions options;
  options.max_held = 3;
  options.most_held_for_loops = 2;
  Inbox inbox(options);
  inbox.offer(0, 0, 0.0, 0);
  drain(inbox, 0.0);
  for (std::uint32_t k = 5; k < 8; ++k) inbox.offer(k, 0, k, int(k));
  EXPECT_EQ(drain(inbox, 0.0), (std::vector<std::uint32_t>{5, 6, 7}));  // the gap bridged at once: 3 held
  inbox.offer(8, 9, 8.0, 8);  // its nine loops never come
  EXPECT_TRUE(drain(inbox, 0.0).empty());
  inbox.offer(9, 9, 9.0, 9);
  EXPECT_TRUE(drain(inbox, 0.0).empty());
  inbox.offer(10, 9, 10.0, 10);
  EXPECT_EQ(drain(inbox, 0.0), (std::vector<std::uint32_t>{8, 9, 10}));
}

TEST(KeyframeInbox, AFrontEndThatStartsAgainIsANewRun) {
  Inbox inbox;
  for (std::uint32_t k = 0; k < 3; ++k) inbox.offer(k, 0, k, int(k));
  drain(inbox, 0.0);
  EXPECT_EQ(inbox.offer(0, 0, 0.0, 0), Inbox::Offer::kAgain);  // the old keyframe 0 again
  EXPECT_EQ(inbox.offer(0, 0, 50.0, 0), Inbox::Offer::kHeld);  // a new keyframe 0: newer than all
  EXPECT_EQ(inbox.offer(1, 0, 51.0, 1), Inbox::Offer::kHeld);
  auto first = inbox.next(0.0);
  ASSERT_TRUE(first);
  EXPECT_TRUE(first->restarted);
  EXPECT_EQ(first->number, 0u);
  auto second = inbox.next(0.0);
  ASSERT_TRUE(second);
  EXPECT_FALSE(second->restarted);
  EXPECT_EQ(inbox.pipelineIndex(0), 3);  // numbers are the new run's
  EXPECT_EQ(inbox.pipelineIndex(1), 4);
  EXPECT_EQ(inbox.frontNumber(4), std::optional<std::uint32_t>(1));
  EXPECT_FALSE(inbox.frontNumber(2));  // of the old run
  EXPECT_EQ(inbox.pipelineCountBelow(1), 4u);
  EXPECT_TRUE(inbox.loopArrived(0, 1));  // loop numbers start again too
  EXPECT_EQ(inbox.counters().restarts, 1u);
}

TEST(KeyframeInbox, ACorruptNumberIsRefused) {
  Inbox inbox;
  inbox.offer(0, 0, 0.0, 0);
  drain(inbox, 0.0);
  std::string why;
  EXPECT_EQ(inbox.offer(4000000000u, 0, 1.0, 1), Inbox::Offer::kRefused);
  EXPECT_EQ(inbox.offer(4000000000u, 0, 1.0, 1, &why), Inbox::Offer::kRefused);
  EXPECT_NE(why.find("past the next expected"), std::string::npos) << why;
  EXPECT_EQ(inbox.counters().refused, 2u);
  EXPECT_EQ(inbox.held(), 0u);
  llc::KeyframeInboxOptions bad;
  bad.max_held = 0;
  EXPECT_NE(bad.validate(), "");
}

}  // namespace
