// Self-training: the training set a mapped drive gives itself, its keyframe pairs labelled by
// their optimised poses. One decision for the train_classifier service (through the front end)
// and `llc train --from-session`.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc {

struct SelfTrainingSet {
  TrainingSet set;                 ///< one row per labelled pair
  std::vector<LabeledPair> pairs;  ///< the pairs, as keyframe indices with their labels
  std::size_t keyframes = 0;       ///< keyframes labelled: those with an optimised pose
  std::size_t positives() const;
  /// "N keyframes, P positive and Q negative pairs labelled by their optimised poses"
  std::string summary() const;
};

/// Every keyframe's scan covers 360 degrees (then a revisit may face any way).
bool allFullCircle(const std::vector<Keyframe>& keyframes);

/// The pairs of the first min(features, poses) keyframes (the back end may not have placed the
/// newest yet) labelled by selfLabelledTrainingSet: never a positive fewer than
/// min_keyframe_gap keyframes apart. Throws std::invalid_argument when the feature vectors are
/// not feature_set's.
SelfTrainingSet selfTrainingSet(const std::vector<std::vector<double>>& features,
                                const std::vector<Pose2>& optimised_poses, FeatureSet feature_set, bool full_circle,
                                std::size_t min_keyframe_gap);
/// The same for a saved session: its keyframes, their features and optimised poses.
SelfTrainingSet selfTrainingSet(const SlamSession& session, FeatureSet feature_set, std::size_t min_keyframe_gap);

}  // namespace llc
