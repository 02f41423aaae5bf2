#include "laser_loop_closure/ros/nodes/classifier_retraining.hpp"

#include <sstream>
#include <stdexcept>

#include "laser_loop_closure/ros/io/drive_input.hpp"

namespace llc_ros {

RetrainingOutcome retrainClassifier(const laser_loop_closure::TrainClassifier::Request& request,
                                    const llc::ClassifierModel& running, const llc::TrainingSet& session,
                                    const std::string& session_text, const std::string& default_model_path) {
  RetrainingOutcome outcome;
  auto& response = outcome.response;
  response.model_path = request.model_path.empty() ? default_model_path : request.model_path;
  try {
    llc::ClassifierTrainingOptions options;
    options.rounds = request.rounds > 0 ? request.rounds : int(running.classifier.stumps().size());
    if (request.folds != 0) options.folds = request.folds;
    if (request.repeats != 0) options.repeats = request.repeats;
    if (request.target_false_alarm != 0.0) options.target_false_alarm = request.target_false_alarm;
    const std::string invalid = options.validate();
    if (!invalid.empty()) throw std::invalid_argument(invalid);

    // Pairs are described with the running model's feature parameters: the stored keyframes'
    // features must stay valid for the new model.
    llc::TrainingSet set;
    std::string data_text;
    if (request.data.empty()) {
      set = session;
      data_text = session_text;
    } else {
      set.dimension = llc::pairFeatureCount(running.features.feature_set);
      std::vector<std::string> warnings;
      for (const std::string& spec : request.data) {
        const PairData item = loadPairData(spec, running.features, BagReadOptions{}, &warnings);
        const llc::TrainingSet part = llc::pairTrainingSet(item.features, item.pairs, running.features.feature_set);
        set.append(part);
        data_text += (data_text.empty() ? "" : " ") + spec;
      }
      if (request.with_session) {
        set.append(session);
        data_text += " + " + session_text;
      }
    }
    response.pairs = set.size();
    llc::ClassifierTrainingResult trained = llc::trainClassifierModel(set, running.features, options);
    trained.model.provenance["data"] = data_text;
    trained.model.provenance["command"] = "~train_classifier service";
    const llc::ModelRates current = llc::rateModel(running.classifier, set, options.target_false_alarm);
    llc::saveClassifierModel(trained.model, response.model_path);

    response.success = true;
    response.detection = trained.detection;
    response.auc = trained.auc;
    response.running_detection = current.detection;
    response.running_auc = current.auc;
    outcome.better_or_equal = trained.detection >= current.detection;
    outcome.model = std::move(trained.model);
    std::ostringstream text;
    text << "trained on " << set.size() << " pairs (" << data_text << "): detection " << trained.detection
         << " at false alarm " << options.target_false_alarm << " (running model: " << current.detection << "), AUC "
         << trained.auc << " (running: " << current.auc << "); saved to " << response.model_path;
    if (!trained.note.empty()) text << "; " << trained.note;
    response.message = text.str();
  } catch (const std::exception& e) {
    response.success = false;
    response.message = std::string("not trained: ") + e.what();
  }
  return outcome;
}

}  // namespace llc_ros
