// SeqReorder: scans put back in their driver's numbering. Hand-worked streams: in order, with
// a dropped message, unnumbered, out of order as the Intel bag is, a gap given up, a straggler,
// a looped bag, wrapping numbers; and a shuffled stream against a sort (the reference).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "laser_loop_closure/core/slam/seq_reorder.hpp"

namespace {

using Numbers = std::vector<std::uint32_t>;

/// Pushes every number (the item is its number), then flushes; what came out, in order.
Numbers run(llc::SeqReorder<std::uint32_t>& reorder, const Numbers& in, bool flush = true) {
  Numbers out;
  for (std::uint32_t seq : in) reorder.push(seq, seq, &out);
  if (flush) reorder.flush(&out);
  return out;
}

llc::SeqReorder<std::uint32_t> window(int scans) {
  llc::SeqReorderOptions o;
  o.scans = scans;
  return llc::SeqReorder<std::uint32_t>(o);
}

TEST(SeqReorder, AStreamInOrderWithGapsOrWithoutNumbersPassesStraightThrough) {
  auto reorder = window(4);
  Numbers out;
  for (std::uint32_t seq : {5u, 6u, 7u, 9u, 10u, 14u}) {  // 8 and 11..13 dropped
    const std::size_t before = out.size();
    reorder.push(seq, seq, &out);
    EXPECT_EQ(out.size(), before + 1) << "scan " << seq << " held";
  }
  EXPECT_EQ(out, (Numbers{5, 6, 7, 9, 10, 14}));
  EXPECT_FALSE(reorder.counters().out_of_order_seen);
  auto unnumbered = window(4);
  EXPECT_EQ(run(unnumbered, {0, 0, 0, 0}, false), (Numbers{0, 0, 0, 0}));
}

TEST(SeqReorder, OnceAScanCameLateTheOnesAfterAreHeldUntilTheMissingOneComes) {
  auto reorder = window(20);
  // The Intel bag near its scan 12040: 12037 comes three places late (its place has passed:
  // skipped), which tells the stream is out of order; then 12044 before 12043 is held.
  Numbers out;
  for (std::uint32_t seq : {12036u, 12038u, 12039u, 12040u, 12037u, 12041u, 12042u}) reorder.push(seq, seq, &out);
  EXPECT_EQ(out, (Numbers{12036, 12038, 12039, 12040, 12041, 12042}));
  EXPECT_TRUE(reorder.counters().out_of_order_seen);
  EXPECT_EQ(reorder.counters().late_skipped, 1u);
  reorder.push(12044, 12044, &out);
  EXPECT_EQ(reorder.held(), 1u);
  EXPECT_EQ(out.back(), 12042u);
  reorder.push(12043, 12043, &out);
  EXPECT_EQ(reorder.held(), 0u);
  EXPECT_EQ(Numbers(out.end() - 2, out.end()), (Numbers{12043, 12044}));
  EXPECT_EQ(reorder.counters().reordered, 1u);
}

TEST(SeqReorder, AMissingScanIsGivenUpWhenMoreThanTheWindowWaitBehindIt) {
  auto reorder = window(3);
  Numbers out;
  for (std::uint32_t seq : {1u, 3u, 2u}) reorder.push(seq, seq, &out);  // 2 late: out of order from now
  EXPECT_EQ(out, (Numbers{1, 3}));
  for (std::uint32_t seq : {5u, 6u, 7u}) reorder.push(seq, seq, &out);  // 4 never comes
  EXPECT_EQ(reorder.held(), 3u);
  reorder.push(8, 8, &out);  // a fourth behind the gap: 4 is given up
  EXPECT_EQ(out, (Numbers{1, 3, 5, 6, 7, 8}));
  EXPECT_EQ(reorder.counters().gaps_given_up, 1u);
  reorder.push(4, 4, &out);  // it came after all: its place has passed
  EXPECT_EQ(reorder.counters().late_skipped, 2u);
  EXPECT_EQ(out.size(), 6u);
}

TEST(SeqReorder, ANumberingThatStartsAgainFlushesTheHeldScansFirst) {
  auto reorder = window(3);
  Numbers out;
  for (std::uint32_t seq : {100u, 102u, 101u, 104u}) reorder.push(seq, seq, &out);  // 104 held (103 missing)
  reorder.push(0, 0, &out);  // a looped bag
  reorder.push(1, 1, &out);
  EXPECT_EQ(out, (Numbers{100, 102, 104, 0, 1}));
  EXPECT_EQ(reorder.counters().restarts, 1u);
  auto jump = window(3);
  EXPECT_EQ(run(jump, {7, 9, 8, 500, 501}), (Numbers{7, 9, 500, 501}));  // a jump ahead beyond any hold (2 x 3)
}

TEST(SeqReorder, NumbersThatWrapAroundStayInOrder) {
  auto reorder = window(4);
  const std::uint32_t top = 0xFFFFFFFFu;
  // top comes after 0: late, skipped; 3 is held until 2 comes.
  EXPECT_EQ(run(reorder, {top - 1, top + 1u /* 0 */, top, 1u, 3u, 2u}), (Numbers{top - 1, 0, 1, 2, 3}));
  auto held = window(4);
  Numbers out;
  for (std::uint32_t seq : {top - 2, top, top - 1 /* late */, 1u, 0u}) held.push(seq, seq, &out);
  EXPECT_EQ(out, (Numbers{top - 2, top, 0, 1}));
}

TEST(SeqReorder, AStreamShuffledWithinTheWindowComesOutSortedButForItsFirstStraggler) {
  // The reference: a sort. Each scan moved by at most 5 places; the window holds 8.
  std::mt19937 random(3);
  Numbers in(2000);
  for (std::uint32_t k = 0; k < in.size(); ++k) in[k] = 1000 + k;
  for (std::size_t k = 0; k + 5 < in.size(); k += 6) std::shuffle(in.begin() + long(k), in.begin() + long(k + 6), random);
  auto reorder = window(8);
  const Numbers out = run(reorder, in);
  // Before the first scan that comes late everything passes as it comes (in order so far);
  // from it on, the missing ones are waited for: the whole output is sorted.
  std::size_t passed = 1;
  while (passed < in.size() && in[passed] > *std::max_element(in.begin(), in.begin() + long(passed))) ++passed;
  ASSERT_LT(passed, in.size());
  EXPECT_TRUE(std::equal(in.begin(), in.begin() + long(passed), out.begin()));
  EXPECT_TRUE(std::is_sorted(out.begin(), out.end()));
  EXPECT_EQ(out.size() + reorder.counters().late_skipped, in.size());
  EXPECT_LE(reorder.counters().late_skipped, 6u);  // only within the first shuffled block
  EXPECT_EQ(reorder.counters().gaps_given_up, 0u);
  EXPECT_EQ(out.back(), in.size() + 999);
}

TEST(SeqReorder, OffHandsOutEveryScanAsItComes) {
  auto reorder = window(0);
  EXPECT_EQ(run(reorder, {3, 1, 2, 2, 9}), (Numbers{3, 1, 2, 2, 9}));
  llc::SeqReorderOptions bad;
  bad.scans = -1;
  EXPECT_FALSE(bad.validate().empty());
  EXPECT_TRUE(llc::SeqReorderOptions{}.validate().empty());
}

}  // namespace
