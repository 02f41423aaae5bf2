#include <gtest/gtest.h>

#include <algorithm>

#include "laser_loop_closure/core/features.hpp"
#include "laser_loop_closure/core/keyframe_store.hpp"
#include "laser_loop_closure/core/random.hpp"

namespace {

TEST(KeyframeStore, ScoresEqualTheClassifierOnPairFeatures) {
  llc::Random random(9);
  const llc::FeatureSet set = llc::FeatureSet::kExtended;
  const std::size_t dim = llc::featureCount(set), count = 5000;  // more than one block
  llc::KeyframeStore store(set);
  std::vector<std::vector<double>> rows;
  for (std::size_t k = 0; k < count; ++k) {
    std::vector<double> f(dim);
    for (double& v : f) v = random.uniform(0, 10);
    rows.push_back(f);
    EXPECT_EQ(store.add(f.data()), k);
  }
  std::vector<llc::Stump> stumps;
  for (int t = 0; t < 30; ++t)
    stumps.push_back({int(random.index(2 * dim)), random.uniform() < 0.5 ? 1 : -1,
                      t % 2 ? random.uniform(0, 5) : random.uniform(0, 0.5), random.uniform(0.1, 2)});
  const llc::StrongClassifier classifier(stumps, 0.6);
  const std::vector<double> query = rows[17];
  std::vector<double> scores;
  store.scoreAll(classifier, query.data(), count - 100, &scores);
  ASSERT_EQ(scores.size(), count - 100);
  for (std::size_t k = 0; k < scores.size(); ++k)
    ASSERT_EQ(scores[k], classifier.score(llc::pairFeatures(set, query, rows[k]).data())) << k;
  const auto candidates = store.query(classifier, query.data(), count, 10);
  ASSERT_FALSE(candidates.empty());
  EXPECT_EQ(candidates[0].score, *std::max_element(scores.begin(), scores.end()));
  for (std::size_t i = 1; i < candidates.size(); ++i) {
    EXPECT_GE(candidates[i - 1].score, candidates[i].score);
    EXPECT_GE(candidates[i].score, 0.6);
  }
}

TEST(KeyframeStore, RefusesAClassifierNeedingMoreFeatures) {
  llc::KeyframeStore store(llc::FeatureSet::kPaper);
  const std::vector<double> f(20, 1.0);
  store.add(f.data());
  const llc::StrongClassifier classifier({{25, 1, 1.0, 1.0}}, 0.5);
  std::vector<double> scores;
  EXPECT_THROW(store.scoreAll(classifier, f.data(), 1, &scores), std::invalid_argument);
}

}  // namespace
