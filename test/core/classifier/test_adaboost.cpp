// Algorithm 1 on a data set small enough to work by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/common/random.hpp"

namespace {

llc::TrainingSet handSet() {
  // One feature: values 1 2 3 4 with labels 1 1 0 1 (N_p = 3, N_n = 1).
  llc::TrainingSet set;
  set.dimension = 1;
  const double values[] = {1, 2, 3, 4};
  const int labels[] = {1, 1, 0, 1};
  for (int i = 0; i < 4; ++i) set.add(&values[i], labels[i]);
  return set;
}

TEST(AdaBoost, TwoRoundsWorkedByHand) {
  // Round 1: weights 1/6 1/6 1/2 1/6. Best stump "F < 2.5" (p = +1) misses only x = 4:
  // error 1/6, beta 1/5, alpha log 5. Correct ones are multiplied by 1/5 and renormalised:
  // 0.1 0.1 0.3 0.5. Round 2: best stump "F > 3.5" (p = -1) misses x = 1, 2: error 0.2,
  // beta 1/4, alpha log 4.
  llc::AdaBoostOptions options;
  options.rounds = 2;
  const llc::AdaBoostResult result = llc::AdaBoostTrainer(options).train(handSet());
  ASSERT_EQ(result.rounds.size(), 2u);
  EXPECT_TRUE(result.stopped_early.empty());
  const llc::Stump& first = result.rounds[0].stump;
  EXPECT_EQ(first.feature, 0);
  EXPECT_EQ(first.polarity, 1);
  EXPECT_DOUBLE_EQ(first.threshold, 2.5);
  EXPECT_NEAR(result.rounds[0].weighted_error, 1.0 / 6, 1e-15);
  EXPECT_NEAR(first.alpha, std::log(5.0), 1e-12);
  const llc::Stump& second = result.rounds[1].stump;
  EXPECT_EQ(second.polarity, -1);
  EXPECT_DOUBLE_EQ(second.threshold, 3.5);
  EXPECT_NEAR(result.rounds[1].weighted_error, 0.2, 1e-12);
  EXPECT_NEAR(second.alpha, std::log(4.0), 1e-12);

  const llc::StrongClassifier& c = result.classifier;
  const double total = std::log(5.0) + std::log(4.0);
  const double f1 = 1, f3 = 3, f4 = 4;
  EXPECT_NEAR(c.score(&f1), std::log(5.0) / total, 1e-12);
  EXPECT_NEAR(c.score(&f3), 0.0, 1e-12);
  EXPECT_NEAR(c.score(&f4), std::log(4.0) / total, 1e-12);
  EXPECT_TRUE(c.isMatch(&f1));   // 0.537 >= 0.5
  EXPECT_FALSE(c.isMatch(&f4));  // 0.463 < 0.5
  EXPECT_EQ(c.prefix(1).stumps().size(), 1u);
  EXPECT_NEAR(c.prefix(1).score(&f4), 0.0, 1e-12);
}

TEST(AdaBoost, PerfectStumpGetsFiniteAlpha) {
  llc::TrainingSet set;
  set.dimension = 2;
  llc::Random random(3);
  for (int i = 0; i < 40; ++i) {
    const double row[2] = {random.uniform(), i % 2 ? 0.1 * random.uniform() : 1.0 + random.uniform()};
    set.add(row, i % 2);
  }
  const llc::AdaBoostResult r = llc::AdaBoostTrainer().train(set);
  ASSERT_FALSE(r.rounds.empty());
  EXPECT_EQ(r.rounds[0].stump.feature, 1);
  EXPECT_TRUE(std::isfinite(r.rounds[0].stump.alpha));
  for (std::size_t i = 0; i < set.size(); ++i) EXPECT_EQ(int(r.classifier.isMatch(set.row(i))), set.labels[i]);
}

TEST(AdaBoost, AllowedFeaturesAreRespected) {
  llc::TrainingSet set;
  set.dimension = 3;
  llc::Random random(5);
  for (int i = 0; i < 60; ++i) {
    const double row[3] = {double(i % 2), random.uniform() + 0.3 * (i % 2), random.uniform()};
    set.add(row, i % 2);
  }
  llc::AdaBoostOptions options;
  options.allowed_features = {1, 2};
  options.rounds = 10;
  for (const auto& round : llc::AdaBoostTrainer(options).train(set).rounds) EXPECT_NE(round.stump.feature, 0);
}

TEST(AdaBoost, OneClassOnlyStopsWithAReason) {
  llc::TrainingSet set;
  set.dimension = 1;
  const double v = 1.0;
  set.add(&v, 1);
  const llc::AdaBoostResult r = llc::AdaBoostTrainer().train(set);
  EXPECT_TRUE(r.rounds.empty());
  EXPECT_FALSE(r.stopped_early.empty());
  const double q = 0.0;
  EXPECT_EQ(r.classifier.score(&q), 0.0);
}

TEST(AdaBoost, OptionsAreValidated) {
  llc::AdaBoostOptions bad;
  bad.rounds = 0;
  EXPECT_THROW(llc::AdaBoostTrainer{bad}, std::invalid_argument);
}

}  // namespace
