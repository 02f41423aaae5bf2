// Helpers shared by the core tests.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/common/random.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/geometry/se2.hpp"

namespace llc_test {

/// A scan with `n` equally spaced beams over the full circle, starting at -pi.
inline llc::Scan ringScan(const std::vector<double>& ranges) {
  llc::Scan scan;
  scan.ranges = ranges;
  scan.full_circle = true;
  const double step = 2.0 * M_PI / double(ranges.size());
  for (std::size_t i = 0; i < ranges.size(); ++i) scan.bearings.push_back(-M_PI + step * double(i));
  return scan;
}

/// A fresh temporary folder, removed with its files when the object goes.
class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/llc_test_XXXXXX";
    path_ = mkdtemp(pattern);
  }
  ~TempDir() { std::system(("rm -rf '" + path_ + "'").c_str()); }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

inline std::string readText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Keyframes driven twice round a 20 m circle (120 per lap): each keyframe's features are a
/// smooth function of where it is, plus noise large enough that no single feature separates
/// the classes (a perfect stump makes every later AdaBoost round repeat it).
inline void circleKeyframes(llc::FeatureSet set, std::vector<std::vector<double>>* features,
                            std::vector<llc::Pose2>* poses) {
  llc::Random random(7);
  const std::size_t per_lap = 120, n = llc::featureCount(set);
  for (std::size_t k = 0; k < 2 * per_lap; ++k) {
    const double angle = 2.0 * M_PI * double(k % per_lap) / double(per_lap);
    poses->push_back(llc::Pose2{20.0 * std::cos(angle), 20.0 * std::sin(angle), angle + M_PI / 2});
    std::vector<double> f(n);
    for (std::size_t i = 0; i < n; ++i)
      f[i] = 5.0 * std::sin(angle + M_PI * double(i) / double(n)) + random.normal(0.0, 0.5);
    features->push_back(f);
  }
}

/// Pairs of circleKeyframes labelled by their poses: 60 per class, any heading.
inline llc::TrainingSet circleTrainingSet(llc::FeatureSet set, std::vector<llc::LabeledPair>* pairs = nullptr) {
  std::vector<std::vector<double>> features;
  std::vector<llc::Pose2> poses;
  circleKeyframes(set, &features, &poses);
  llc::PairLabelingOptions labeling;
  labeling.full_circle = true;
  labeling.max_pairs_per_class = 60;
  return llc::keyframeTrainingSet(features, poses, set, labeling, pairs);
}

/// The shipped classifier.
inline llc::ClassifierModel defaultModel() {
  return llc::loadClassifierModel(std::string(LLC_SOURCE_DIR) + "/config/classifier.yaml");
}

/// The simulated drive through the default world, length_m of route.
inline llc::SimDrive simulatedDrive(double length_m) {
  llc::SimDriveOptions options;
  options.length_m = length_m;
  const llc::SimWorld world(llc::simWorldOptions(options));
  return llc::simulateDrive(world, options);
}

/// The 360-degree scan of one simulated frame, as the bag reader merges it.
inline llc::Scan frameScan(const llc::SimDrive& drive, const llc::SimFrame& frame) {
  auto one = [&](const llc::SimScannerOptions& scanner, const std::vector<double>& ranges) {
    llc::ScannerGeometry g;
    g.angle_min = llc::simBeamAngle(scanner, 0);
    g.angle_increment = llc::simBeamAngle(scanner, 1) - g.angle_min;
    g.range_max = scanner.max_range;
    return llc::scanFromRanges(ranges, g, scanner.mount, frame.stamp);
  };
  llc::Scan scan = llc::mergeScans(one(drive.front, frame.front), one(drive.back, frame.back));
  scan.stamp = frame.stamp;
  return scan;
}

/// The front scanner's 180-degree scan of one simulated frame, alone.
inline llc::Scan frontScan(const llc::SimDrive& drive, const llc::SimFrame& frame) {
  llc::ScannerGeometry g;
  g.angle_min = llc::simBeamAngle(drive.front, 0);
  g.angle_increment = llc::simBeamAngle(drive.front, 1) - g.angle_min;
  g.range_max = drive.front.max_range;
  return llc::scanFromRanges(frame.front, g, drive.front.mount, frame.stamp);
}

/// ../shared/data beside the repository, or "" when absent.
inline std::string sharedDataDir() {
  const char* env = std::getenv("LLC_DATA_DIR");
  const std::string dir = env ? env : std::string(LLC_SOURCE_DIR) + "/../shared/data";
  return std::ifstream(dir + "/README.md") ? dir : "";
}

}  // namespace llc_test
