#include "laser_loop_closure/ros/io/drive_input.hpp"

#include <fstream>
#include <stdexcept>
#include <tuple>

#include "laser_loop_closure/core/io/carmen_reader.hpp"

namespace llc_ros {

namespace {
bool endsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}
}  // namespace

bool isBagPath(const std::string& path) { return endsWith(path, ".bag"); }

llc::ScanSequence loadDrive(const std::string& path, const BagReadOptions& bag, std::vector<std::string>* warnings) {
  if (!std::ifstream(path)) throw std::runtime_error(path + ": no such file or not readable");
  llc::ScanSequence sequence;
  if (isBagPath(path)) {
    BagReadReport report;
    sequence = readBagSequence(path, bag, &report);  // BagError is a runtime_error
    if (report.skipped_scans > 0 && warnings)
      warnings->push_back(path + ": skipped " + std::to_string(report.skipped_scans) +
                          " front scans; the first: " + report.first_problem);
    if (report.damaged_messages > 0 && warnings)
      warnings->push_back(path + ": left out " + std::to_string(report.damaged_messages) +
                          " damaged messages; the first: " + report.first_damaged);
    if (warnings)
      for (const std::string& frame : report.fallback_frames)
        warnings->push_back(path + ": /tf_static does not mount scanner frame '" + frame +
                            "' on the base frame; it is taken to sit at x " + std::to_string(bag.fallback_mount.x) +
                            " m, y " + std::to_string(bag.fallback_mount.y) + " m, yaw " +
                            std::to_string(bag.fallback_mount.theta) + " rad");
    const llc::SeqReorderCounters& order = report.seq_reorder;
    if (order.out_of_order_seen && warnings)
      warnings->push_back(path + ": front scans out of their header.seq order (mapped without wheel odometry, so "
                          "put back in it): " + std::to_string(order.reordered) + " held for the ones before them, " +
                          std::to_string(order.late_skipped) + " skipped as late, " + std::to_string(order.gaps_given_up) +
                          " missing numbers given up");
    if (report.truth_from_odometry && warnings)
      warnings->push_back(path + ": no messages on the truth topic; poses come from odometry");
  } else {
    sequence = llc::loadScanSequence(path);  // CarmenError is a runtime_error
  }
  if (sequence.scans.empty()) throw std::runtime_error(path + ": the log holds no laser scan");
  return sequence;
}

std::pair<std::string, std::string> splitDataSpec(const std::string& spec) {
  const std::size_t colon = spec.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == spec.size())
    throw std::invalid_argument("expected LOG:PAIRS, not '" + spec + "'");
  return {spec.substr(0, colon), spec.substr(colon + 1)};
}

std::vector<std::vector<double>> extractAll(const llc::ScanSequence& sequence, const llc::FeatureOptions& options) {
  llc::FeatureExtractor extractor(options);
  std::vector<std::vector<double>> features;
  features.reserve(sequence.scans.size());
  for (const llc::LoggedScan& s : sequence.scans) features.push_back(extractor.extract(s.scan));
  return features;
}

PairData loadPairData(const std::string& spec, const llc::FeatureOptions& features, const BagReadOptions& bag,
                      std::vector<std::string>* warnings) {
  PairData item;
  std::tie(item.log_path, item.pairs_path) = splitDataSpec(spec);
  item.sequence = loadDrive(item.log_path, bag, warnings);
  item.pairs = llc::readPairs(item.pairs_path, item.sequence.scans.size());  // PairFileError: runtime_error
  item.features = extractAll(item.sequence, features);
  return item;
}

}  // namespace llc_ros
