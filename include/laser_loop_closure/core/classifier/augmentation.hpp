// Training-pair augmentation: the labelled pairs of a log seen again as another scanner would
// have recorded them. A model trained on 180-beam logs detects less on 360-beam ones (and the
// other way round, more so): its stumps' thresholds sit where one beam count puts the
// features. Each augmented copy keeps the pair's label and transforms both scans alike, so
// it teaches the model what changes with the scanner and what does not.
#pragma once

#include <string>
#include <vector>

#include "laser_loop_closure/core/classifier/adaboost.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/features/features.hpp"
#include "laser_loop_closure/core/geometry/scan.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"

namespace llc {

enum class ScanAugmentation {
  kHalfBeams,    ///< every second beam: a scanner of half the resolution over the same field
  kDoubleBeams,  ///< a beam between every two: twice the resolution (ranges interpolated)
};
/// "half-beams", "double-beams".
const char* scanAugmentationName(ScanAugmentation kind);
/// A comma-separated list of those names ("" or "none": no augmentation); throws
/// std::invalid_argument naming the unknown entry or a repeated one.
std::vector<ScanAugmentation> parseScanAugmentations(const std::string& list);

/// Every second beam, from the first (ranges and bearings kept).
Scan halfBeams(const Scan& scan);
/// A beam at the mid bearing between every two neighbours (and between the last and the first
/// of a full circle). Its range: the mean of the two when both returned and differ by at most
/// max_jump (m; one surface), the nearer when they differ more (the edge of the nearer
/// surface hides the farther), no return (the first non-finite of the two) when either has none.
Scan doubleBeams(const Scan& scan, double max_jump = 0.2);
Scan augmentScan(const Scan& scan, ScanAugmentation kind);

/// The rows of `pairs` of `log` (as pairTrainingSet) with both scans of every pair transformed by
/// `kind` and described again by `extractor`; labels kept. Only the scans the pairs name are
/// transformed.
TrainingSet augmentedPairSet(const ScanSequence& log, const std::vector<LabeledPair>& pairs, ScanAugmentation kind,
                             FeatureExtractor& extractor);

}  // namespace llc
