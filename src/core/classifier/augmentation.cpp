#include "laser_loop_closure/core/classifier/augmentation.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "laser_loop_closure/core/classifier/classifier_training.hpp"

namespace llc {

const char* scanAugmentationName(ScanAugmentation kind) {
  switch (kind) {
    case ScanAugmentation::kHalfBeams: return "half-beams";
    case ScanAugmentation::kDoubleBeams: return "double-beams";
  }
  return "half-beams";
}

std::vector<ScanAugmentation> parseScanAugmentations(const std::string& list) {
  std::vector<ScanAugmentation> kinds;
  if (list.empty() || list == "none") return kinds;
  std::stringstream in(list);
  std::string name;
  while (std::getline(in, name, ',')) {
    ScanAugmentation kind;
    if (name == "half-beams") kind = ScanAugmentation::kHalfBeams;
    else if (name == "double-beams") kind = ScanAugmentation::kDoubleBeams;
    else throw std::invalid_argument("unknown augmentation '" + name + "' (half-beams, double-beams or none)");
    if (std::find(kinds.begin(), kinds.end(), kind) != kinds.end())
      throw std::invalid_argument("augmentation '" + name + "' given twice");
    kinds.push_back(kind);
  }
  if (kinds.empty()) throw std::invalid_argument("no augmentation named in '" + list + "'");
  return kinds;
}

Scan halfBeams(const Scan& scan) {
  Scan out;
  out.stamp = scan.stamp;
  out.full_circle = scan.full_circle;
  const std::size_t n = std::min(scan.ranges.size(), scan.bearings.size());
  for (std::size_t i = 0; i < n; i += 2) out.ranges.push_back(scan.ranges[i]), out.bearings.push_back(scan.bearings[i]);
  return out;
}

Scan doubleBeams(const Scan& scan, double max_jump) {
  Scan out;
  out.stamp = scan.stamp;
  out.full_circle = scan.full_circle;
  const std::size_t n = std::min(scan.ranges.size(), scan.bearings.size());
  auto between = [&](double a, double b) {
    if (!std::isfinite(a)) return a;
    if (!std::isfinite(b)) return b;
    return std::abs(a - b) <= max_jump ? 0.5 * (a + b) : std::min(a, b);
  };
  for (std::size_t i = 0; i < n; ++i) {
    out.ranges.push_back(scan.ranges[i]);
    out.bearings.push_back(scan.bearings[i]);
    const bool wraps = i + 1 == n;
    if (wraps && !(scan.full_circle && n >= 2)) break;
    const std::size_t j = wraps ? 0 : i + 1;
    // Across the wrap the next bearing is a full turn on; a mid bearing past pi goes first.
    const double next = wraps ? scan.bearings[j] + 2.0 * M_PI : scan.bearings[j];
    const double mid = 0.5 * (scan.bearings[i] + next), range = between(scan.ranges[i], scan.ranges[j]);
    if (wraps && mid >= M_PI) {
      out.ranges.insert(out.ranges.begin(), range);
      out.bearings.insert(out.bearings.begin(), mid - 2.0 * M_PI);
    } else {
      out.ranges.push_back(range);
      out.bearings.push_back(mid);
    }
  }
  return out;
}

Scan augmentScan(const Scan& scan, ScanAugmentation kind) {
  return kind == ScanAugmentation::kHalfBeams ? halfBeams(scan) : doubleBeams(scan);
}

TrainingSet augmentedPairSet(const ScanSequence& log, const std::vector<LabeledPair>& pairs, ScanAugmentation kind,
                             FeatureExtractor& extractor) {
  const std::vector<LoggedScan>& scans = log.scans;
  std::vector<std::vector<double>> features(scans.size());
  for (const LabeledPair& p : pairs)
    for (const std::size_t index : {p.a, p.b}) {
      if (index >= scans.size()) throw std::invalid_argument("augmentation: a pair names a scan beyond the log");
      if (features[index].empty()) features[index] = extractor.extract(augmentScan(scans[index].scan, kind));
    }
  return pairTrainingSet(features, pairs, extractor.options().feature_set);
}

}  // namespace llc
