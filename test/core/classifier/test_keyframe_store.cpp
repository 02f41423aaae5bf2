#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/classifier/keyframe_store.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/features/range_profile.hpp"

namespace {

/// Feature vectors of random room-like scans: realistic values, profiles included.
std::vector<std::vector<double>> randomKeyframes(std::size_t count, std::uint64_t seed) {
  llc::Random random(seed);
  llc::FeatureExtractor extractor;
  std::vector<std::vector<double>> rows;
  for (std::size_t k = 0; k < count; ++k) {
    llc::Scan scan;
    scan.full_circle = k % 3 != 0;  // some 180-degree scans
    const std::size_t beams = scan.full_circle ? 72 : 37;
    const double span = scan.full_circle ? 2 * M_PI : M_PI;
    double r = random.uniform(1, 10);
    for (std::size_t i = 0; i < beams; ++i) {
      r = std::clamp(r + random.uniform(-0.5, 0.5), 0.3, 30.0);
      scan.bearings.push_back(-span / 2 + span * double(i) / double(beams));
      scan.ranges.push_back(random.uniform() < 0.05 ? INFINITY : r);
    }
    rows.push_back(extractor.extract(scan));
  }
  return rows;
}

llc::KeyframeStore storeOf(const std::vector<std::vector<double>>& rows) {
  llc::KeyframeStore store(llc::FeatureSet::kExtended);
  for (const auto& row : rows) store.add(row.data());
  return store;
}

/// A classifier over every kind of pair feature: scalar, relative, signature, profile.
/// With profile_below, every profile stump votes "match" below its threshold (the case in which
/// the query may stop a profile distance at the largest threshold).
llc::StrongClassifier mixedClassifier(llc::Random& random, double k, bool profile_below = false) {
  const llc::FeatureSet set = llc::FeatureSet::kExtended;
  const std::size_t pairs = llc::pairFeatureCount(set);
  std::vector<llc::Stump> stumps;
  for (int t = 0; t < 40; ++t) {
    const int feature = t % 10 == 0 ? int(llc::profilePairFeature(set))
                        : t % 7 == 0 ? int(pairs - 2 - random.index(6))
                                     : int(random.index(2 * llc::scalarFeatureCount(set)));
    const bool profile = feature == int(llc::profilePairFeature(set));
    const int polarity = random.uniform() < 0.5 || (profile && profile_below) ? 1 : -1;
    stumps.push_back({feature, polarity, random.uniform(0, 1), random.uniform(0.1, 2)});
  }
  return llc::StrongClassifier(stumps, k);
}

TEST(KeyframeStore, ScoresEqualTheClassifierOnPairFeaturesOfTheStoredKeyframe) {
  llc::Random random(9);
  const llc::FeatureSet set = llc::FeatureSet::kExtended;
  const std::size_t count = 5000;  // more than one block
  const auto rows = randomKeyframes(count, 3);
  llc::KeyframeStore store(set);
  for (std::size_t k = 0; k < count; ++k) EXPECT_EQ(store.add(rows[k].data()), k);
  // Stored values are the features rounded to float.
  EXPECT_EQ(store.feature(11, 4), double(float(rows[11][4])));
  const llc::StrongClassifier classifier = mixedClassifier(random, 0.6);
  const std::vector<double> query = rows[17];
  std::vector<double> scores;
  store.scoreAll(classifier, query.data(), count - 100, &scores);
  ASSERT_EQ(scores.size(), count - 100);
  for (std::size_t k = 0; k < scores.size(); ++k)
    ASSERT_EQ(scores[k], classifier.score(llc::pairFeatures(set, query, store.features(k)).data())) << k;
}

TEST(KeyframeStore, QueryFindsExactlyTheKeyframesScoringAtLeastK) {
  llc::Random random(5);
  const std::size_t count = 7000;
  const auto rows = randomKeyframes(count, 4);
  const llc::KeyframeStore store = storeOf(rows);
  for (double k : {0.3, 0.5, 0.7, 0.9, 0.3, 0.5, 0.7, 0.9}) {
    static int round = 0;
    const llc::StrongClassifier classifier = mixedClassifier(random, k, round++ >= 4);
    for (std::size_t q : {std::size_t(0), std::size_t(123), count - 1}) {
      std::vector<double> scores;
      store.scoreAll(classifier, rows[q].data(), count, &scores);
      std::vector<std::size_t> expected;
      for (std::size_t i = 0; i < count; ++i)
        if (scores[i] >= k) expected.push_back(i);
      const auto candidates = store.query(classifier, rows[q].data(), count, count);
      std::vector<std::size_t> found;
      for (const auto& c : candidates) {
        found.push_back(c.keyframe);
        EXPECT_NEAR(c.score, scores[c.keyframe], 1e-12);
      }
      for (std::size_t i = 1; i < candidates.size(); ++i) EXPECT_GE(candidates[i - 1].score, candidates[i].score);
      std::sort(found.begin(), found.end());
      EXPECT_EQ(found, expected) << "K " << k << " query " << q;
      // The cap keeps the best ones.
      const auto top = store.query(classifier, rows[q].data(), count, 3);
      ASSERT_EQ(top.size(), std::min<std::size_t>(3, candidates.size()));
      for (std::size_t i = 0; i < top.size(); ++i) EXPECT_EQ(top[i].keyframe, candidates[i].keyframe);
    }
  }
}

// A capped query raises its bar to the lowest score it holds (shared among threads): it must
// still return exactly the head of the uncapped answer, ties broken by keyframe, whatever the
// number of threads. Low K, so that far more keyframes than the cap pass it.
TEST(KeyframeStore, CappedQueryIsTheHeadOfTheFullAnswerForAnyThreadCount) {
  llc::Random random(12);
  const std::size_t count = 9000;  // several blocks per thread
  const auto rows = randomKeyframes(count, 8);
  const llc::KeyframeStore store = storeOf(rows);
  for (double k : {0.2, 0.4, 0.6}) {
    const llc::StrongClassifier classifier = mixedClassifier(random, k, k > 0.3);
    for (std::size_t q : {std::size_t(5), std::size_t(4321)}) {
      const auto all = store.query(classifier, rows[q].data(), count, count);
      ASSERT_GT(all.size(), 50u) << "K " << k << ": too few pass K to test the cap";
      for (std::size_t cap : {std::size_t(1), std::size_t(3), std::size_t(17), all.size() - 1})
        for (std::size_t threads : {std::size_t(1), std::size_t(2), std::size_t(3)}) {
          const auto top = store.query(classifier, rows[q].data(), count, cap, threads);
          ASSERT_EQ(top.size(), cap) << "K " << k << " cap " << cap << " threads " << threads;
          for (std::size_t i = 0; i < cap; ++i) {
            EXPECT_EQ(top[i].keyframe, all[i].keyframe) << "K " << k << " cap " << cap << " threads " << threads;
            EXPECT_EQ(top[i].score, all[i].score);
          }
        }
      EXPECT_TRUE(store.query(classifier, rows[q].data(), count, 0).empty());
    }
  }
}

TEST(KeyframeStore, AKeyframeAlwaysMatchesItself) {
  const auto rows = randomKeyframes(50, 6);
  const llc::KeyframeStore store = storeOf(rows);
  const std::vector<double> own = store.features(20);
  const std::vector<double> pair = llc::pairFeatures(llc::FeatureSet::kExtended, own, own);
  for (double v : pair) EXPECT_EQ(v, 0.0);
  // A classifier voting "match" on small differences gives it the full score.
  std::vector<llc::Stump> stumps = {{0, 1, 0.1, 1.0}, {int(llc::profilePairFeature(llc::FeatureSet::kExtended)), 1, 0.01, 1.0}};
  const auto candidates = store.query(llc::StrongClassifier(stumps, 1.0), own.data(), 50, 50);
  ASSERT_FALSE(candidates.empty());
  EXPECT_EQ(candidates[0].score, 1.0);
  EXPECT_TRUE(std::any_of(candidates.begin(), candidates.end(), [](const auto& c) { return c.keyframe == 20; }));
}

TEST(KeyframeStore, RefusesAClassifierNeedingMoreFeatures) {
  llc::KeyframeStore store(llc::FeatureSet::kPaper);
  const std::vector<double> f(20, 1.0);
  store.add(f.data());
  const llc::StrongClassifier classifier({{25, 1, 1.0, 1.0}}, 0.5);
  std::vector<double> scores;
  EXPECT_THROW(store.scoreAll(classifier, f.data(), 1, &scores), std::invalid_argument);
  EXPECT_THROW(store.query(classifier, f.data(), 1, 1), std::invalid_argument);
  EXPECT_THROW(store.features(3), std::out_of_range);
}

}  // namespace
