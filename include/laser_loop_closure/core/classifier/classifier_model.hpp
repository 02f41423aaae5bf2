// The classifier model file: YAML, versioned; records T, the stumps, K and the feature
// parameters the stumps were trained on.
#pragma once

#include <map>
#include <stdexcept>
#include <string>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/features/features.hpp"

namespace llc {

constexpr int kClassifierModelVersion = 1;

struct ClassifierModel {
  FeatureOptions features;     ///< how scans must be described for these stumps
  StrongClassifier classifier;  ///< stumps and K
  /// Free-form provenance (training data, command, cross-validated rates), kept as text.
  std::map<std::string, std::string> provenance;
};

/// Why a model file was refused; what() names the file and the problem.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes the model to a temporary file beside `path` and renames it over `path`, so that a
/// crash during the save leaves the old file intact. Throws ModelError when it cannot write.
void saveClassifierModel(const ClassifierModel& model, const std::string& path);

/// Reads and checks a model file. Refuses (throws ModelError) a file that is missing, not
/// YAML, truncated, of another version, inconsistent (stump count, feature names, values out
/// of range), or — when `expected` is given — made with other feature parameters.
ClassifierModel loadClassifierModel(const std::string& path,
                                    const FeatureOptions* expected = nullptr);

}  // namespace llc
