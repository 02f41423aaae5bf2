// Model file round trip and every refusal.
#include <gtest/gtest.h>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "../test_util.hpp"

namespace {

llc::ClassifierModel sampleModel() {
  llc::ClassifierModel model;
  model.features.feature_set = llc::FeatureSet::kPaper;
  model.classifier = llc::StrongClassifier(
      {{0, 1, 0.1234567890123456789, 1.5}, {14, -1, 3.0e-7, 0.25}, {19, 1, 12.5, 2.0 / 3.0}}, 0.5);
  model.provenance["data"] = "a.log:a.csv";
  return model;
}

void expectRefused(const std::string& path, const std::string& fragment,
                   const llc::FeatureOptions* expected = nullptr) {
  try {
    llc::loadClassifierModel(path, expected);
    ADD_FAILURE() << "accepted " << path;
  } catch (const llc::ModelError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << "names the file: " << e.what();
  }
}

TEST(ClassifierModel, RoundTripIsExact) {
  llc_test::TempDir dir;
  const llc::ClassifierModel model = sampleModel();
  llc::saveClassifierModel(model, dir.file("m.yaml"));
  const llc::ClassifierModel back = llc::loadClassifierModel(dir.file("m.yaml"), &model.features);
  EXPECT_EQ(back.features, model.features);
  EXPECT_EQ(back.classifier.thresholdK(), model.classifier.thresholdK());
  ASSERT_EQ(back.classifier.stumps().size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const llc::Stump &a = back.classifier.stumps()[i], &b = model.classifier.stumps()[i];
    EXPECT_EQ(a.feature, b.feature);
    EXPECT_EQ(a.polarity, b.polarity);
    EXPECT_EQ(a.threshold, b.threshold);  // bit for bit
    EXPECT_EQ(a.alpha, b.alpha);
  }
  EXPECT_EQ(back.provenance.at("data"), "a.log:a.csv");
  EXPECT_FALSE(std::ifstream(dir.file("m.yaml.tmp")).good()) << "the temporary file is renamed away";
}

TEST(ClassifierModel, RefusesBadFiles) {
  llc_test::TempDir dir;
  const std::string good = dir.file("good.yaml");
  llc::saveClassifierModel(sampleModel(), good);
  const std::string text = llc_test::readText(good);
  auto variant = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string changed = text;
    const std::size_t at = changed.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    changed.replace(at, from.size(), to);
    llc_test::writeText(dir.file(name), changed);
    return dir.file(name);
  };

  expectRefused(dir.file("missing.yaml"), "cannot open");
  llc_test::writeText(dir.file("garbage.yaml"), "{{{ [ not yaml");
  expectRefused(dir.file("garbage.yaml"), "not valid YAML");
  llc_test::writeText(dir.file("other.yaml"), "a: 1\n");
  expectRefused(dir.file("other.yaml"), "not a classifier model");
  llc_test::writeText(dir.file("empty.yaml"), "");
  expectRefused(dir.file("empty.yaml"), "not a classifier model");
  for (std::size_t cut : {text.size() / 3, text.size() / 2, text.size() - 20}) {
    const std::string name = "cut" + std::to_string(cut) + ".yaml";
    llc_test::writeText(dir.file(name), text.substr(0, cut));
    try {
      llc::loadClassifierModel(dir.file(name));
      ADD_FAILURE() << "accepted a file cut at " << cut;
    } catch (const llc::ModelError&) {
    }
  }
  expectRefused(variant("v2.yaml", "version: 1", "version: 2"), "version 2 is not supported");
  expectRefused(variant("rounds.yaml", "rounds: 3", "rounds: 4"), "truncated");
  expectRefused(variant("polarity.yaml", "polarity: -1", "polarity: 0"), "polarity");
  expectRefused(variant("alpha.yaml", "alpha: 1.5", "alpha: .nan"), "alpha");
  expectRefused(variant("huge_alpha.yaml", "alpha: 1.5", "alpha: 4294967295"), "alpha 4294967295 above 745");
  expectRefused(variant("index.yaml", "feature: 19", "feature: 25"), "out of range");
  expectRefused(variant("names.yaml", "area", "areal"), "feature names differ");
  expectRefused(variant("k.yaml", "threshold_k: 0.5", "threshold_k: 1.5"), "threshold_k");
  expectRefused(variant("type.yaml", "threshold: 12.5", "threshold: twelve"), "wrong type");
  // A model that cannot match anything: no stump, or no stump with any weight.
  {
    llc::ClassifierModel empty = sampleModel();
    empty.classifier = llc::StrongClassifier({}, 0.5);
    llc::saveClassifierModel(empty, dir.file("no_rounds.yaml"));
    expectRefused(dir.file("no_rounds.yaml"), "no stump has a positive alpha (rounds: 0)");
    llc::ClassifierModel weightless = sampleModel();
    weightless.classifier = llc::StrongClassifier({{0, 1, 0.5, 0.0}, {3, -1, 1.0, 0.0}}, 0.5);
    llc::saveClassifierModel(weightless, dir.file("zero_alpha.yaml"));
    expectRefused(dir.file("zero_alpha.yaml"), "no stump has a positive alpha (rounds: 2)");
  }

  llc::FeatureOptions other = sampleModel().features;
  other.r_max = 30.0;
  expectRefused(good, "other feature parameters", &other);
  other = sampleModel().features;
  other.feature_set = llc::FeatureSet::kExtended;
  expectRefused(good, "feature_set", &other);
}

TEST(ClassifierModel, SaveToUnwritablePlaceThrows) {
  EXPECT_THROW(llc::saveClassifierModel(sampleModel(), "/nonexistent-dir/m.yaml"), llc::ModelError);
}

}  // namespace
