#include "laser_loop_closure/core/slam/self_training.hpp"

#include <algorithm>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/classifier_training.hpp"

namespace llc {

std::size_t SelfTrainingSet::positives() const {
  return std::size_t(std::count_if(pairs.begin(), pairs.end(), [](const LabeledPair& p) { return p.label == 1; }));
}

std::string SelfTrainingSet::summary() const {
  const std::size_t positive = positives();
  return std::to_string(keyframes) + " keyframes, " + std::to_string(positive) + " positive and " +
         std::to_string(pairs.size() - positive) + " negative pairs labelled by their optimised poses";
}

bool allFullCircle(const std::vector<Keyframe>& keyframes) {
  return std::all_of(keyframes.begin(), keyframes.end(), [](const Keyframe& k) { return k.scan.full_circle; });
}

SelfTrainingSet selfTrainingSet(const std::vector<std::vector<double>>& features,
                                const std::vector<Pose2>& optimised_poses, FeatureSet feature_set, bool full_circle,
                                std::size_t min_keyframe_gap) {
  SelfTrainingSet result;
  result.keyframes = std::min(features.size(), optimised_poses.size());
  for (std::size_t k = 0; k < result.keyframes; ++k)
    if (features[k].size() != featureCount(feature_set))
      throw std::invalid_argument("keyframe " + std::to_string(k) + " has " + std::to_string(features[k].size()) +
                                  " feature values, not the " + std::to_string(featureCount(feature_set)) + " of the " +
                                  toString(feature_set) + " set");
  if (features.size() == optimised_poses.size()) {  // the usual case: no copy
    result.set = selfLabelledTrainingSet(features, optimised_poses, feature_set, full_circle, min_keyframe_gap,
                                         &result.pairs);
    return result;
  }
  const std::vector<std::vector<double>> placed(features.begin(), features.begin() + long(result.keyframes));
  const std::vector<Pose2> poses(optimised_poses.begin(), optimised_poses.begin() + long(result.keyframes));
  result.set = selfLabelledTrainingSet(placed, poses, feature_set, full_circle, min_keyframe_gap, &result.pairs);
  return result;
}

SelfTrainingSet selfTrainingSet(const SlamSession& session, FeatureSet feature_set, std::size_t min_keyframe_gap) {
  return selfTrainingSet(session.features, session.poses, feature_set, allFullCircle(session.keyframes),
                         min_keyframe_gap);
}

}  // namespace llc
