// The ~train_classifier service's work without a master (retrainClassifier): pairs from the
// session or from LOG:PAIRS files, the running model rated on the same pairs, the new model
// saved and readable, and every failure answered with success = false and a reason.
#include <gtest/gtest.h>

#include "../core/test_util.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/ros/nodes/classifier_retraining.hpp"

namespace {

const llc::FeatureSet kSet = llc::FeatureSet::kPaper;

llc::TrainingSet circleSession() { return llc_test::circleTrainingSet(kSet); }

/// A running model of one stump: worse than what 20 rounds learn.
llc::ClassifierModel weakModel(const llc::TrainingSet& set) {
  llc::ClassifierModel model;
  model.features.feature_set = kSet;
  llc::AdaBoostOptions one;
  one.rounds = 1;
  model.classifier = llc::AdaBoostTrainer(one).train(set).classifier;
  return model;
}

TEST(ClassifierRetraining, SessionPairsTrainSaveAndRateTheRunningModel) {
  llc_test::TempDir dir;
  const llc::TrainingSet session = circleSession();
  const llc::ClassifierModel running = weakModel(session);
  laser_loop_closure::TrainClassifier::Request request;
  request.rounds = 20;
  request.folds = 5;
  const llc_ros::RetrainingOutcome outcome =
      llc_ros::retrainClassifier(request, running, session, "session: test", dir.file("new.yaml"));
  const auto& r = outcome.response;
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_FALSE(r.swapped);  // the node swaps, not this function
  EXPECT_EQ(r.pairs, session.size());
  EXPECT_EQ(r.model_path, dir.file("new.yaml"));
  const llc::ModelRates expected = llc::rateModel(running.classifier, session, 0.01);
  EXPECT_DOUBLE_EQ(r.running_detection, expected.detection);
  EXPECT_DOUBLE_EQ(r.running_auc, expected.auc);
  EXPECT_GE(r.detection, 0.9);
  EXPECT_EQ(outcome.better_or_equal, r.detection >= r.running_detection);
  EXPECT_TRUE(outcome.better_or_equal) << r.message;
  const llc::ClassifierModel saved = llc::loadClassifierModel(dir.file("new.yaml"));
  EXPECT_EQ(saved.classifier.stumps().size(), 20u);
  EXPECT_EQ(saved.provenance.at("data"), "session: test");
  EXPECT_TRUE(saved.features == running.features);
}

TEST(ClassifierRetraining, PairsFromALogFileAndBadRequestsAreAnswered) {
  llc_test::TempDir dir;
  llc::SimDriveOptions options;
  options.seed = 3;
  options.length_m = 150.0;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive drive = llc::simulateDrive(world, options);
  llc::writeCarmenLog(drive, dir.file("drive.log"));
  // Consecutive scans (0.1 s apart) are the same place; scans half the drive apart are not.
  const std::size_t half = drive.frames.size() / 2;
  ASSERT_GT(half, 100u);
  std::vector<llc::LabeledPair> pairs;
  for (std::size_t k = 0; k + half < drive.frames.size() && pairs.size() < 200; k += 3) {
    pairs.push_back({k, k + 1, 1});
    pairs.push_back({k, k + half, 0});
  }
  llc::writePairs(dir.file("pairs.csv"), pairs);
  const llc::TrainingSet no_session;
  llc::ClassifierModel running = weakModel(circleSession());

  laser_loop_closure::TrainClassifier::Request request;
  request.data = {dir.file("drive.log") + ":" + dir.file("pairs.csv")};
  request.model_path = dir.file("from_log.yaml");
  request.rounds = 10;
  auto r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.pairs, pairs.size());
  EXPECT_EQ(llc::loadClassifierModel(dir.file("from_log.yaml")).provenance.at("data"), request.data[0]);
  // with_session: the session's pairs beside the file's (self-training).
  const llc::TrainingSet session = circleSession();
  request.with_session = true;
  request.model_path = dir.file("with_session.yaml");
  r = llc_ros::retrainClassifier(request, running, session, "session: test", "unused.yaml").response;
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.pairs, pairs.size() + session.size());
  EXPECT_EQ(llc::loadClassifierModel(dir.file("with_session.yaml")).provenance.at("data"), request.data[0] + " + session: test");
  request.with_session = false;

  request.data = {dir.file("missing.log") + ":" + dir.file("pairs.csv")};
  r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("missing.log"), std::string::npos) << r.message;

  request.data = {"no-colon-here"};
  r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("LOG:PAIRS"), std::string::npos) << r.message;

  request.data.clear();  // an empty session: too few pairs
  r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.message.empty());

  request.data = {dir.file("drive.log") + ":" + dir.file("pairs.csv")};
  request.model_path = dir.file("no/such/folder/m.yaml");
  r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  EXPECT_FALSE(r.success);

  request.model_path = dir.file("m.yaml");
  request.folds = 1;
  r = llc_ros::retrainClassifier(request, running, no_session, "", "unused.yaml").response;
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("folds"), std::string::npos) << r.message;
}

}  // namespace
