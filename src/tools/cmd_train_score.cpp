// llc train, llc score.
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/classifier/evaluation.hpp"
#include "laser_loop_closure/core/slam/loop_detector.hpp"
#include "laser_loop_closure/core/slam/self_training.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"

namespace llc_tool {

int runTrain(const Args& args) {
  const std::string model_path = args.required("model");
  const llc::FeatureOptions features = featureOptions(args);
  const std::vector<std::string> specs = args.all("data");
  // Every flag and the output checked before the pairs are loaded and the model trained.
  llc::ClassifierTrainingOptions options;
  options.rounds = int(args.integer("rounds", options.rounds));
  options.folds = int(args.integer("folds", options.folds));
  options.repeats = int(args.integer("repeats", options.repeats));
  const long seed = args.integer("seed", long(options.seed));
  if (seed < 0) throw UsageError("--seed must be zero or more");
  options.seed = std::uint64_t(seed);
  options.target_false_alarm = args.number("target-false-alarm", options.target_false_alarm);
  options.excluded_features = excludedFeatures(args, features);
  if (const std::string invalid = options.validate(); !invalid.empty()) throw UsageError(invalid);
  const double given_k = args.number("k", 0.5);
  if (args.has("k") && !(given_k >= 0.0 && given_k <= 1.0)) throw UsageError("--k must lie in [0, 1]");
  // --from-session S (any number): self-training, the session's keyframe pairs labelled by
  // its optimised map added to the labelled pairs (the session's features must be this set's).
  llc::SystemOptions system;  // loops/min_keyframe_gap: the gap the nodelet's self-training keeps too
  applyParameterFlags(args, &system);
  const std::vector<llc::ScanAugmentation> kinds = augmentations(args);
  if (!kinds.empty() && specs.empty()) throw UsageError("--augment needs --data LOG:PAIRS (a session's keyframes are not augmented)");
  checkOutputFile("model", model_path);

  const std::vector<PairData> data =
      specs.empty() && args.has("from-session") ? std::vector<PairData>{} : loadPairData(specs, features, args);
  llc::TrainingSet set = pairTrainingSet(data, features.feature_set);
  // Each augmentation kind's rows, one for one with the --data rows (session rows have none).
  std::vector<llc::TrainingSet> companions;
  for (const std::vector<llc::TrainingSet>& kind : augmentedSets(data, kinds, features)) {
    companions.emplace_back();
    companions.back().dimension = set.dimension;
    for (const llc::TrainingSet& rows : kind) companions.back().append(rows);
  }
  std::ostringstream session_text;
  for (const std::string& path : args.all("from-session")) {
    llc::SlamSession session;
    try {
      session = llc::loadSession(path);
    } catch (const llc::SessionError& e) {
      throw ToolError(e.what());
    }
    llc::SelfTrainingSet own;
    try {
      own = llc::selfTrainingSet(session, features.feature_set, system.slam.loops.min_keyframe_gap);
    } catch (const std::invalid_argument& e) {
      throw ToolError(path + ": " + e.what() + " (--features/set)");
    }
    if (!companions.empty()) throw UsageError("--augment and --from-session cannot be combined");
    set.append(own.set);
    std::cout << "session " << path << ": " << own.summary() << "\n";
    session_text << (session_text.tellp() ? " " : "") << path;
  }
  if (set.size() == 0) throw ToolError("no training pairs: give --data LOG:PAIRS and/or --from-session SESSION");

  llc::ClassifierTrainingResult trained;
  try {
    trained = llc::trainClassifierModel(set, features, options, companions.empty() ? nullptr : &companions);
  } catch (const std::invalid_argument& e) {
    throw ToolError(e.what());
  }
  llc::ClassifierModel& model = trained.model;
  std::ostringstream data_text;
  for (const std::string& spec : specs) data_text << (data_text.tellp() ? " " : "") << spec;
  model.provenance["data"] = data_text.str();
  if (session_text.tellp()) model.provenance["self_training_sessions"] = session_text.str();
  if (!kinds.empty()) model.provenance["augment"] = args.get("augment", "");
  if (args.has("k")) {
    model.classifier.setThresholdK(given_k);
    model.provenance["threshold_k"] = "given with --k";
  }
  llc::saveClassifierModel(model, model_path);
  std::cout << "pairs=" << set.size() << " rounds=" << model.classifier.stumps().size()
            << " threshold_k=" << model.classifier.thresholdK() << " detection_at_target=" << trained.detection
            << " auc=" << trained.auc << " -> " << model_path << "\n";
  if (!trained.note.empty()) std::cout << "note: " << trained.note << "\n";
  return 0;
}

int runScore(const Args& args) {
  const std::string model_path = args.get("model", defaultModelPath());
  const std::string out_path = args.required("out");
  checkOutputFile("out", out_path);
  llc::ClassifierModel model;
  try {
    model = llc::loadClassifierModel(model_path);
  } catch (const llc::ModelError& e) {
    throw ToolError(e.what());
  }
  const std::vector<llc::ScanAugmentation> kinds = augmentations(args);
  if (kinds.size() > 1) throw UsageError("--augment: llc score takes one kind (the scanner the pairs are seen by)");
  const std::vector<PairData> data = loadPairData(args.all("data"), model.features, args);
  // --augment KIND: every pair scored as a scanner of that kind would have seen its two scans.
  std::vector<llc::TrainingSet> augmented;
  if (!kinds.empty()) augmented = augmentedSets(data, kinds, model.features).front();
  llc::AtomicTextFile out(out_path);
  out << "a,b,label,score\n" << std::setprecision(17);
  std::vector<double> row, scores;
  std::vector<int> labels;
  std::size_t matches = 0, total = 0;
  for (std::size_t d = 0; d < data.size(); ++d)
    for (std::size_t i = 0; i < data[d].pairs.size(); ++i) {
      const llc::LabeledPair& p = data[d].pairs[i];
      row = llc::pairFeatures(model.features.feature_set, data[d].features[p.a], data[d].features[p.b]);
      const double score = model.classifier.score(augmented.empty() ? row.data() : augmented[d].row(i));
      matches += score >= model.classifier.thresholdK();
      ++total;
      scores.push_back(score), labels.push_back(p.label);
      out << p.a << ',' << p.b << ',' << p.label << ',' << score << '\n';
    }
  out.commit();
  std::cout << "pairs=" << total << " matches=" << matches << " (K=" << model.classifier.thresholdK()
            << ", model " << model_path << ") -> " << out_path << "\n"
            << "detection_at_1pct_fa=" << llc::detectionAtFalseAlarm(scores, labels, 0.01)
            << " auc=" << llc::areaUnderCurve(scores, labels) << "  (best threshold on these pairs)\n";
  return 0;
}

}  // namespace llc_tool
