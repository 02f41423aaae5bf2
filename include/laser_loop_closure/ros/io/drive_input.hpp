// Recorded drives and labelled pairs as the tools and the ~train_classifier service read them:
// a CARMEN log (.log, .log.gz, any other name) or a rosbag (.bag), with a pair file (a,b,label).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"

namespace llc_ros {

/// Whether loadDrive reads `path` as a rosbag (by its .bag suffix) rather than a CARMEN log.
bool isBagPath(const std::string& path);

/// Reads a drive. Throws std::runtime_error naming the file and the problem (missing file,
/// malformed log or bag, no laser scan). Problems met but survived (skipped scans, poses from
/// odometry for lack of truth) are appended to `warnings`.
llc::ScanSequence loadDrive(const std::string& path, const BagReadOptions& bag, std::vector<std::string>* warnings);

/// The feature vector of every scan of a drive, in order.
std::vector<std::vector<double>> extractAll(const llc::ScanSequence& sequence, const llc::FeatureOptions& options);

/// One LOG:PAIRS item, loaded: the scans, their feature vectors and the pairs.
struct PairData {
  std::string log_path, pairs_path;
  llc::ScanSequence sequence;
  std::vector<std::vector<double>> features;  ///< one vector per scan
  std::vector<llc::LabeledPair> pairs;
};

/// Splits LOG:PAIRS at the last ':'; throws std::invalid_argument when it is not of that form.
std::pair<std::string, std::string> splitDataSpec(const std::string& spec);
/// Loads one LOG:PAIRS item with the features of every scan. Throws std::runtime_error.
PairData loadPairData(const std::string& spec, const llc::FeatureOptions& features, const BagReadOptions& bag,
                      std::vector<std::string>* warnings);

}  // namespace llc_ros
