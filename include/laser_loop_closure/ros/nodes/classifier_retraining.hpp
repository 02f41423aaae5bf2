// The work of the ~train_classifier service, without the node: pairs from LOG:PAIRS items or
// from the session's keyframes, AdaBoost with K from cross-validated scores, the running model
// rated on the same pairs, the new model saved. The caller swaps it in when `better_or_equal`.
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/TrainClassifier.h"
#include "laser_loop_closure/core/classifier/classifier_training.hpp"

namespace llc_ros {

struct RetrainingOutcome {
  laser_loop_closure::TrainClassifier::Response response;  ///< swapped is left false
  llc::ClassifierModel model;  ///< the new one (when response.success)
  bool better_or_equal = false;  ///< new cross-validated detection >= the running model's on the same pairs
};

/// `session` holds the session's labelled keyframe pairs; it is used when request.data is
/// empty (then `session_text` describes it in the model's provenance). Never throws: every
/// failure (unreadable data, too few pairs, unwritable file) comes back as success = false.
RetrainingOutcome retrainClassifier(const laser_loop_closure::TrainClassifier::Request& request,
                                    const llc::ClassifierModel& running, const llc::TrainingSet& session,
                                    const std::string& session_text, const std::string& default_model_path);

}  // namespace llc_ros
