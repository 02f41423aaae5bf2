// llc train, llc score.
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "commands.hpp"
#include "laser_loop_closure/core/classifier_model.hpp"
#include "laser_loop_closure/core/classifier_training.hpp"
#include "laser_loop_closure/core/evaluation.hpp"

namespace llc_tool {

int runTrain(const Args& args) {
  const std::string model_path = args.required("model");
  const llc::FeatureOptions features = featureOptions(args);
  const std::vector<std::string> specs = args.all("data");
  const std::vector<PairData> data = loadPairData(specs, features, args);
  const llc::TrainingSet set = pairTrainingSet(data, features.feature_set);

  llc::ClassifierTrainingOptions options;
  options.rounds = int(args.integer("rounds", options.rounds));
  options.folds = int(args.integer("folds", options.folds));
  options.repeats = int(args.integer("repeats", options.repeats));
  options.seed = std::uint64_t(args.integer("seed", long(options.seed)));
  options.target_false_alarm = args.number("target-false-alarm", options.target_false_alarm);
  llc::ClassifierTrainingResult trained;
  try {
    trained = llc::trainClassifierModel(set, features, options);
  } catch (const std::invalid_argument& e) {
    throw ToolError(e.what());
  }
  llc::ClassifierModel& model = trained.model;
  std::ostringstream data_text;
  for (const std::string& spec : specs) data_text << (data_text.tellp() ? " " : "") << spec;
  model.provenance["data"] = data_text.str();
  if (args.has("k")) {
    const double k = args.number("k", 0.5);
    if (!(k >= 0.0 && k <= 1.0)) throw ToolError("--k must lie in [0, 1]");
    model.classifier.setThresholdK(k);
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
  llc::ClassifierModel model;
  try {
    model = llc::loadClassifierModel(model_path);
  } catch (const llc::ModelError& e) {
    throw ToolError(e.what());
  }
  const std::vector<PairData> data = loadPairData(args.all("data"), model.features, args);
  std::ofstream out(out_path);
  if (!out) throw ToolError(out_path + ": cannot write");
  out << "a,b,label,score\n" << std::setprecision(17);
  std::vector<double> row;
  std::size_t matches = 0, total = 0;
  for (const PairData& item : data)
    for (const llc::LabeledPair& p : item.pairs) {
      row = llc::pairFeatures(model.features.feature_set, item.features[p.a], item.features[p.b]);
      const double score = model.classifier.score(row.data());
      matches += score >= model.classifier.thresholdK();
      ++total;
      out << p.a << ',' << p.b << ',' << p.label << ',' << score << '\n';
    }
  std::cout << "pairs=" << total << " matches=" << matches << " (K=" << model.classifier.thresholdK()
            << ", model " << model_path << ") -> " << out_path << "\n";
  return 0;
}

}  // namespace llc_tool
