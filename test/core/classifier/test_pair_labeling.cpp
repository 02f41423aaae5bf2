#include <gtest/gtest.h>

#include <set>

#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "../test_util.hpp"

namespace {

// A robot driving three times round a 20 m x 20 m square, a pose every 0.5 m.
std::vector<llc::Pose2> squareLoops() {
  std::vector<llc::Pose2> poses;
  for (int lap = 0; lap < 3; ++lap)
    for (int side = 0; side < 4; ++side)
      for (int step = 0; step < 40; ++step) {
        const double s = 0.5 * step;
        const double heading = side * M_PI / 2;
        const double xs[] = {s, 20, 20 - s, 0}, ys[] = {0, s, 20, 20 - s};
        poses.push_back({xs[side], ys[side], llc::normalizeAngle(heading)});
      }
  return poses;
}

TEST(PairLabeling, RulesAndBalance) {
  const std::vector<llc::Pose2> poses = squareLoops();
  llc::PairLabelingOptions options;
  const llc::PairLabelingResult result = llc::labelPairs(poses, options);
  std::size_t positives = 0;
  for (const llc::LabeledPair& p : result.pairs) {
    ASSERT_LT(p.a, p.b);
    const double d = std::hypot(poses[p.b].x - poses[p.a].x, poses[p.b].y - poses[p.a].y);
    if (p.label == 1) {
      ++positives;
      EXPECT_LT(d, 1.5);
      EXPECT_GE(p.b - p.a, 30u);
      EXPECT_LE(std::abs(llc::normalizeAngle(poses[p.b].theta - poses[p.a].theta)), M_PI / 4 + 1e-12);
    } else {
      EXPECT_GT(d, 10.0);
    }
  }
  EXPECT_EQ(positives, 200u);
  EXPECT_EQ(result.pairs.size(), 400u);
  EXPECT_GT(result.positive_candidates, 200u);
  // Seeded: the same seed gives the same pairs, another seed others.
  EXPECT_EQ(llc::labelPairs(poses, options).pairs.size(), 400u);
  const auto again = llc::labelPairs(poses, options).pairs;
  for (std::size_t i = 0; i < again.size(); ++i) EXPECT_EQ(again[i].a, result.pairs[i].a);
  options.seed = 2;
  const auto other = llc::labelPairs(poses, options).pairs;
  bool differs = false;
  for (std::size_t i = 0; i < other.size(); ++i) differs = differs || other[i].a != result.pairs[i].a;
  EXPECT_TRUE(differs);
}

TEST(PairLabeling, HeadingGateAndFullCircle) {
  // Two passes over the same line in opposite directions.
  std::vector<llc::Pose2> poses;
  for (int i = 0; i < 40; ++i) poses.push_back({0.5 * i, 0, 0});
  for (int i = 0; i < 40; ++i) poses.push_back({19.5 - 0.5 * i, 0, M_PI});
  llc::PairLabelingOptions options;
  options.min_index_gap = 10;
  EXPECT_EQ(llc::labelPairs(poses, options).positive_candidates, 0u);
  options.full_circle = true;
  EXPECT_GT(llc::labelPairs(poses, options).positive_candidates, 0u);
}

TEST(PairLabeling, ExtraNegativesAreFarApartDistinctAndSeeded) {
  std::vector<llc::Pose2> line;
  for (int k = 0; k < 40; ++k) line.push_back({double(k), 0.0, 0.0});  // 1 m apart
  const std::vector<llc::LabeledPair> some = llc::sampleNegativePairs(line, 10.0, 50, 7);
  ASSERT_EQ(some.size(), 50u);
  std::set<std::pair<std::size_t, std::size_t>> seen;
  for (const llc::LabeledPair& p : some) {
    EXPECT_LT(p.a, p.b);
    EXPECT_GT(p.b - p.a, 10u);  // farther than 10 m
    EXPECT_EQ(p.label, 0);
    EXPECT_TRUE(seen.insert({p.a, p.b}).second) << "a pair drawn twice";
  }
  const std::vector<llc::LabeledPair> again = llc::sampleNegativePairs(line, 10.0, 50, 7);
  for (std::size_t i = 0; i < some.size(); ++i) {
    EXPECT_EQ(again[i].a, some[i].a);
    EXPECT_EQ(again[i].b, some[i].b);
  }
  // Gaps 11..39: sum of (40 - gap) = 29 + 28 + ... + 1 = 435 pairs in all; asking for more gives them all.
  EXPECT_EQ(llc::sampleNegativePairs(line, 10.0, 10000, 7).size(), 435u);
  EXPECT_TRUE(llc::sampleNegativePairs(line, 100.0, 10, 7).empty());
}

TEST(PairLabeling, PairFileRoundTripAndErrors) {
  llc_test::TempDir dir;
  const std::vector<llc::LabeledPair> pairs = {{1, 40, 1}, {2, 90, 0}};
  llc::writePairs(dir.file("p.csv"), pairs);
  const auto back = llc::readPairs(dir.file("p.csv"), 100);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].b, 90u);
  EXPECT_EQ(back[0].label, 1);
  EXPECT_THROW(llc::readPairs(dir.file("p.csv"), 50), llc::PairFileError);  // 90 out of range
  try {
    llc::readPairs(dir.file("p.csv"), 50);
  } catch (const llc::PairFileError& e) {
    EXPECT_NE(std::string(e.what()).find(":3: scan index 90 out of range"), std::string::npos) << e.what();
  }
  for (const char* body : {"", "x,y\n1,2,1\n", "a,b,label\n1,2\n", "a,b,label\n1,-2,1\n", "a,b,label\n1,2,7\n",
                           "a,b,label\n1,zz,1\n"}) {
    llc_test::writeText(dir.file("bad.csv"), body);
    EXPECT_THROW(llc::readPairs(dir.file("bad.csv"), 100), llc::PairFileError) << body;
  }
  EXPECT_THROW(llc::readPairs(dir.file("none.csv"), 100), llc::PairFileError);
}

}  // namespace
