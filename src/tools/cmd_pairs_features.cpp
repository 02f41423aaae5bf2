// llc pairs, llc features.
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "commands.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"

namespace llc_tool {

int runPairs(const Args& args) {
  const std::string log = args.required("log"), out = args.required("out");
  llc::PairLabelingOptions options;
  options.positive_max_distance = args.number("positive-distance", options.positive_max_distance);
  options.positive_max_heading =
      args.number("positive-heading-deg", options.positive_max_heading * 180.0 / M_PI) * M_PI / 180.0;
  const long gap = args.integer("min-gap", long(options.min_index_gap));
  const long per_class = args.integer("max-per-class", long(options.max_pairs_per_class));
  const long seed = args.integer("seed", long(options.seed));
  if (gap < 0 || per_class < 1 || seed < 0)
    throw UsageError("--min-gap must be >= 0, --max-per-class >= 1 and --seed >= 0");
  options.min_index_gap = std::size_t(gap);
  options.max_pairs_per_class = std::size_t(per_class);
  options.seed = std::uint64_t(seed);
  options.negative_min_distance = args.number("negative-distance", options.negative_min_distance);
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  checkOutputFile("out", out);

  const llc::ScanSequence sequence = loadSequence(log, args);
  bool all_full = true;
  for (const llc::LoggedScan& s : sequence.scans) all_full = all_full && s.scan.full_circle;
  options.full_circle = args.has("full-circle") || (all_full && !args.has("partial"));
  std::vector<llc::Pose2> poses;
  for (const llc::LoggedScan& s : sequence.scans) poses.push_back(s.truth);
  const llc::PairLabelingResult result = llc::labelPairs(poses, options);
  try {
    llc::writePairs(out, result.pairs);
  } catch (const llc::PairFileError& e) {
    throw ToolError(e.what());
  }
  std::cout << "scans=" << poses.size() << " positive_candidates=" << result.positive_candidates
            << " pairs=" << result.pairs.size() << " (" << result.pairs.size() / 2 << " per class, "
            << (options.full_circle ? "any heading" : "heading-gated") << ") -> " << out << "\n";
  return 0;
}

int runFeatures(const Args& args) {
  const std::string log = args.required("log"), out_path = args.required("out");
  const llc::FeatureOptions options = featureOptions(args);
  const std::vector<llc::ScanAugmentation> kinds = augmentations(args);
  if (kinds.size() > 1) throw UsageError("--augment: llc features takes one kind (the scanner the scans are seen by)");
  checkOutputFile("out", out_path);
  llc::ScanSequence sequence = loadSequence(log, args);
  // --augment KIND: every scan as a scanner of that kind would have recorded it.
  if (!kinds.empty())
    for (llc::LoggedScan& s : sequence.scans) s.scan = llc::augmentScan(s.scan, kinds.front());
  const std::vector<std::vector<double>> features = extractAll(sequence, options);
  llc::AtomicTextFile out(out_path);
  out << "index,stamp";
  for (const std::string& name : llc::featureNames(options.feature_set)) out << ',' << name;
  out << '\n' << std::setprecision(17);
  for (std::size_t i = 0; i < features.size(); ++i) {
    out << i << ',' << sequence.scans[i].stamp;
    for (double v : features[i]) out << ',' << v;
    out << '\n';
  }
  out.commit();
  std::cout << "scans=" << features.size() << " features=" << (features.empty() ? 0 : features[0].size())
            << " -> " << out_path << "\n";
  return 0;
}

}  // namespace llc_tool
