#include "tool_common.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "laser_loop_closure/core/classifier/classifier_training.hpp"
#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/ros/io/drive_input.hpp"

namespace llc_tool {

// The keys of a model file's `features:` section (docs/file_formats.md, "Model file").
const std::vector<std::string> kFeatureFlags = {"features/set", "features/r_max", "features/g_max_dist",
                                                "features/g_min_size", "features/closed_ring"};
const std::vector<std::string> kInputFlags = {"front-topic", "back-topic", "odom-topic", "truth-topic",
                                              "odometry-time-offset"};

llc_ros::BagReadOptions bagOptions(const Args& args) {
  llc_ros::BagReadOptions options;
  options.topics.front = args.get("front-topic", options.topics.front);
  options.topics.back = args.get("back-topic", options.topics.back);
  options.topics.odom = args.get("odom-topic", options.topics.odom);
  options.topics.truth = args.get("truth-topic", options.topics.truth);
  options.odometry_time_offset = args.number("odometry-time-offset", 0.0);
  if (!(std::fabs(options.odometry_time_offset) <= 1.0))
    throw UsageError("--odometry-time-offset must be in [-1, 1] s");
  return options;
}

void applyParameterFlags(const Args& args, llc::SystemOptions* options) {
  std::vector<std::pair<std::string, std::string>> values;
  for (const std::string& name : llc::systemParameterNames())
    for (const std::string& value : args.all(name)) values.emplace_back(name, value);
  if (values.empty()) return;
  try {
    llc::setSystemParameters(values, "the command line", options);
  } catch (const std::exception& e) {
    throw UsageError(e.what());
  }
}

std::vector<std::string> parameterNamesUnder(const std::string& prefix, const std::vector<std::string>& except) {
  std::vector<std::string> names;
  for (const std::string& name : llc::systemParameterNames())
    if (name.rfind(prefix, 0) == 0 && std::find(except.begin(), except.end(), name) == except.end()) names.push_back(name);
  return names;
}

void systemParametersHelp(std::ostream& out, const std::string& prefix) {
  // The meaning of each parameter from the comment beside it in config/slam.yaml, keyed by its
  // nested name (indentation gives the sections).
  std::map<std::string, std::string> comments;
  std::ifstream yaml(configFilePath("slam.yaml"));
  std::vector<std::pair<std::size_t, std::string>> sections;
  for (std::string line; std::getline(yaml, line);) {
    const std::size_t indent = line.find_first_not_of(' ');
    if (indent == std::string::npos || line[indent] == '#') continue;
    const std::size_t colon = line.find(':', indent);
    if (colon == std::string::npos) continue;
    while (!sections.empty() && sections.back().first >= indent) sections.pop_back();
    const std::string key = line.substr(indent, colon - indent);
    const std::size_t hash = line.find('#', colon);
    const std::string value = line.substr(colon + 1, hash == std::string::npos ? std::string::npos : hash - colon - 1);
    std::string name;
    for (const auto& section : sections) name += section.second + "/";
    if (value.find_first_not_of(' ') == std::string::npos) {
      sections.emplace_back(indent, key);
      continue;
    }
    if (hash != std::string::npos) comments[name + key] = line.substr(line.find_first_not_of(' ', hash + 1));
  }
  out << (prefix.empty() ? std::string("pipeline parameters") : "parameters " + prefix + "*")
      << " (each also a key of config/slam.yaml and a ROS parameter of the nodelets; default, then meaning):\n";
  for (const auto& parameter : llc::systemParameterDefaults()) {
    if (parameter.first.rfind(prefix, 0) != 0) continue;
    out << "  --" << parameter.first << " " << parameter.second;
    auto comment = comments.find(parameter.first);
    if (comment == comments.end()) {  // a block the file documents once (aligner/icp: "as above")
      const std::size_t cut = parameter.first.rfind('/', parameter.first.rfind('/') - 1);
      const std::string tail = cut == std::string::npos ? parameter.first : parameter.first.substr(cut);
      comment = std::find_if(comments.begin(), comments.end(), [&](const auto& c) {
        return c.first.size() > tail.size() && c.first.compare(c.first.size() - tail.size(), tail.size(), tail) == 0;
      });
    }
    if (comment != comments.end()) out << "   # " << comment->second;
    out << "\n";
  }
}

Args::Args(int argc, char** argv, const std::vector<std::string>& options,
           const std::vector<std::string>& flags) {
  auto known = [](const std::vector<std::string>& list, const std::string& name) {
    for (const std::string& item : list)
      if (item == name) return true;
    return false;
  };
  for (int i = 0; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + word + "'");
    const std::string name = word.substr(2);
    if (known(flags, name)) {
      values_.emplace(name, "1");
    } else if (known(options, name)) {
      if (i + 1 >= argc) throw UsageError("--" + name + " needs a value");
      values_.emplace(name, argv[++i]);
    } else {
      throw UsageError("unknown option --" + name);
    }
  }
}

bool Args::has(const std::string& name) const { return values_.count(name) > 0; }

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

std::string Args::required(const std::string& name) const {
  if (!has(name)) throw UsageError("--" + name + " is required");
  return get(name, "");
}

std::vector<std::string> Args::all(const std::string& name) const {
  std::vector<std::string> out;
  auto range = values_.equal_range(name);
  for (auto it = range.first; it != range.second; ++it) out.push_back(it->second);
  return out;
}

double Args::number(const std::string& name, double fallback) const {
  if (!has(name)) return fallback;
  const std::string text = get(name, "");
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(value))
    throw UsageError("--" + name + " must be a number, not '" + text + "'");
  return value;
}

long Args::integer(const std::string& name, long fallback) const {
  if (!has(name)) return fallback;
  const std::string text = get(name, "");
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0') throw UsageError("--" + name + " must be a whole number, not '" + text + "'");
  return value;
}

bool Args::boolean(const std::string& name, bool fallback) const {
  if (!has(name)) return fallback;
  const std::string text = get(name, "");
  if (text == "true") return true;
  if (text == "false") return false;
  throw UsageError("--" + name + " must be true or false, not '" + text + "'");
}

llc::FeatureOptions featureOptions(const Args& args) {
  llc::FeatureOptions options;
  const std::string set = args.get("features/set", llc::toString(options.feature_set));
  if (!llc::parseFeatureSet(set, &options.feature_set))
    throw UsageError("--features/set must be 'paper' or 'extended', not '" + set + "'");
  options.r_max = args.number("features/r_max", options.r_max);
  options.g_max_dist = args.number("features/g_max_dist", options.g_max_dist);
  options.g_min_size = int(args.integer("features/g_min_size", options.g_min_size));
  options.closed_ring = args.boolean("features/closed_ring", options.closed_ring);
  const std::string invalid = options.validate();
  if (!invalid.empty()) throw UsageError("feature options: " + invalid);
  return options;
}

llc_ros::BagReadOptions driveReadOptions(const std::string& path, const Args& args) {
  if (args.has("odometry-time-offset") && !llc_ros::isBagPath(path))
    throw UsageError("--odometry-time-offset is for a bag (a log's odometry moves by whole scans: --odometry-offset)");
  return bagOptions(args);
}

llc::ScanSequence loadSequence(const std::string& path, const Args& args, bool mapping, llc::OdometryTimeOffsetProbe* probe) {
  std::vector<std::string> warnings;
  llc::ScanSequence sequence;
  llc_ros::BagReadOptions bag_options = driveReadOptions(path, args);  // a bad flag: UsageError, not ToolError
  bag_options.odometry_time_offset_probe = probe;
  if (mapping) {
    const bool without_wheels = args.has("no-wheel-odometry");
    bag_options.skip_scans_outside_odometry = !without_wheels;
    bag_options.without_wheels = without_wheels;
    bag_options.seq_reorder.scans = int(args.integer("seq-reorder-scans", llc::SeqReorderOptions{}.scans));
    const std::string invalid = bag_options.seq_reorder.validate();
    if (!invalid.empty()) throw UsageError("--seq-reorder-scans: " + invalid);
    if (args.has("seq-reorder-scans") && !llc_ros::isBagPath(path))
      throw UsageError("--seq-reorder-scans is for a bag (a log's lines are in the order they were written)");
  }
  try {
    sequence = llc_ros::loadDrive(path, bag_options, &warnings);
  } catch (const std::runtime_error& e) {
    throw ToolError(e.what());
  }
  for (const std::string& warning : warnings) std::cerr << "warning: " << warning << "\n";
  return sequence;
}

std::vector<PairData> loadPairData(const std::vector<std::string>& specs, const llc::FeatureOptions& options,
                                   const Args& args) {
  if (specs.empty()) throw UsageError("--data LOG:PAIRS is required");
  std::vector<PairData> data;
  for (const std::string& spec : specs) {
    std::vector<std::string> warnings;
    try {
      data.push_back(llc_ros::loadPairData(spec, options, bagOptions(args), &warnings));
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--data: ") + e.what());
    } catch (const std::runtime_error& e) {
      throw ToolError(e.what());
    }
    for (const std::string& warning : warnings) std::cerr << "warning: " << warning << "\n";
  }
  return data;
}

llc::TrainingSet pairTrainingSet(const std::vector<PairData>& data, llc::FeatureSet feature_set) {
  llc::TrainingSet set;
  set.dimension = llc::pairFeatureCount(feature_set);
  for (const PairData& item : data) {
    const llc::TrainingSet part = llc::pairTrainingSet(item.features, item.pairs, feature_set);
    set.append(part);
  }
  return set;
}

std::vector<llc::ScanAugmentation> augmentations(const Args& args) {
  try {
    return llc::parseScanAugmentations(args.get("augment", "none"));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--augment: ") + e.what());
  }
}

std::vector<std::string> excludedFeatures(const Args& args, const llc::FeatureOptions& options) {
  std::vector<std::string> excluded;
  if (!args.has("exclude-features")) return excluded;
  const std::vector<std::string>& names = llc::pairFeatureNames(options.feature_set);
  std::stringstream in(args.get("exclude-features", ""));
  std::string name;
  while (std::getline(in, name, ',')) {
    if (std::find(names.begin(), names.end(), name) == names.end())
      throw UsageError("--exclude-features: no pair feature '" + name + "' in the " + llc::toString(options.feature_set) +
                       " set (the names of a model file's features)");
    excluded.push_back(name);
  }
  if (excluded.empty()) throw UsageError("--exclude-features: no feature named");
  return excluded;
}

std::vector<std::vector<llc::TrainingSet>> augmentedSets(const std::vector<PairData>& data,
                                                         const std::vector<llc::ScanAugmentation>& kinds,
                                                         const llc::FeatureOptions& options) {
  llc::FeatureExtractor extractor(options);
  std::vector<std::vector<llc::TrainingSet>> sets;
  for (const llc::ScanAugmentation kind : kinds) {
    sets.emplace_back();
    for (const PairData& item : data) sets.back().push_back(llc::augmentedPairSet(item.sequence, item.pairs, kind, extractor));
  }
  return sets;
}

std::string configFilePath(const std::string& name) {
  for (const char* dir : {LLC_SOURCE_CONFIG_DIR, LLC_INSTALL_CONFIG_DIR}) {
    const std::string path = std::string(dir) + "/" + name;
    if (std::ifstream(path)) return path;
  }
  return std::string(LLC_SOURCE_CONFIG_DIR) + "/" + name;
}

std::string defaultModelPath() { return configFilePath("classifier.yaml"); }

void ensureDirectory(const std::string& path) {
  std::string partial;
  for (std::size_t i = 0; i <= path.size(); ++i) {
    if (i == path.size() || path[i] == '/') {
      if (!partial.empty() && mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST)
        throw ToolError(path + ": cannot create the folder (" + std::strerror(errno) + ")");
    }
    if (i < path.size()) partial += path[i];
  }
  struct stat info;
  if (stat(path.c_str(), &info) != 0 || !S_ISDIR(info.st_mode))
    throw ToolError(path + ": not a folder");
}

void checkOutputFile(const std::string& flag, const std::string& path) {
  const std::string why = llc::whyNotWritable(path);
  if (!why.empty()) throw ToolError("--" + flag + " " + path + ": cannot be written (" + why + ")");
}

void prepareOutputFolder(const std::string& flag, const std::string& path) {
  try {
    ensureDirectory(path);
  } catch (const ToolError& e) {
    throw ToolError("--" + flag + " " + e.what());
  }
  if (::access(path.c_str(), W_OK | X_OK) != 0)
    throw ToolError("--" + flag + " " + path + ": cannot write into the folder (" + std::strerror(errno) + ")");
}

const std::vector<std::string> kDriftFlags = {"drift", "drift-scale-bias", "drift-heading", "drift-noise-m",
                                              "drift-noise-rad", "drift-noise-share", "drift-seed"};

std::optional<llc::OdometryDrift> odometryDrift(const Args& args) {
  bool any = false;
  for (const std::string& f : kDriftFlags) any = any || args.has(f);
  if (!any) return std::nullopt;
  llc::OdometryDrift drift;  // moderate: the defaults
  const std::string preset = args.get("drift", "moderate");
  if (preset == "strong") {
    drift.scale_bias *= 2, drift.heading_drift *= 2, drift.noise_translation *= 2, drift.noise_rotation *= 2, drift.noise_fraction *= 2;
  } else if (preset != "moderate") {
    throw UsageError("--drift must be 'moderate' or 'strong', not '" + preset + "'");
  }
  drift.scale_bias = args.number("drift-scale-bias", drift.scale_bias);
  drift.heading_drift = args.number("drift-heading", drift.heading_drift);
  drift.noise_translation = args.number("drift-noise-m", drift.noise_translation);
  drift.noise_rotation = args.number("drift-noise-rad", drift.noise_rotation);
  drift.noise_fraction = args.number("drift-noise-share", drift.noise_fraction);
  const long seed = args.integer("drift-seed", 1);
  if (seed < 0) throw UsageError("--drift-seed must be zero or more");
  drift.seed = std::uint64_t(seed);
  const std::string invalid = drift.validate();
  if (!invalid.empty()) throw UsageError(invalid);
  return drift;
}

void writeMapFiles(const std::vector<llc::Keyframe>& keyframes, const std::vector<llc::Pose2>& poses,
                   const std::vector<llc::PictureLoop>& loops, const llc::OccupancyGridOptions& options, const std::string& dir) {
  std::vector<const llc::Scan*> scans;
  for (const llc::Keyframe& k : keyframes) scans.push_back(&k.scan);
  try {
    const llc::OccupancyGrid grid = llc::buildOccupancyGrid(scans, poses, options);
    llc::saveMapFiles(grid, dir + "/map", options);
    llc::renderMapPicture(grid, poses, loops).savePng(dir + "/map.png");
  } catch (const std::exception& e) {
    throw ToolError(std::string("map: ") + e.what());
  }
}

std::string saveLifelongSession(const llc::SlamSession& session, const llc::SessionPruningOptions& options,
                                const std::string& path, const std::string& dir) {
  llc::SessionPruningResult pruning;
  llc::SlamSession pruned;
  try {
    pruned = llc::pruneSession(session, options, &pruning);
    llc::saveSession(pruned, path);
  } catch (const std::exception& e) {
    throw ToolError(e.what());
  }
  llc::AtomicTextFile list(dir + "/session_keyframes.csv");
  list << "robot,index,stamp,x,y,theta\n" << std::fixed << std::setprecision(6);
  for (std::size_t k = 0; k < pruned.keyframes.size(); ++k) {
    const llc::Pose2& p = pruned.poses[k];
    list << (pruned.robots.empty() ? 0u : pruned.robots[k]) << "," << pruned.keyframes[k].scan_index << ","
         << pruned.keyframes[k].stamp << "," << p.x << "," << p.y << "," << p.theta << "\n";
  }
  list.commit();
  std::ostringstream lines;
  lines << std::setprecision(4) << "session_keyframes=" << pruning.keyframes_after << "  (saved; of " << pruning.keyframes_before
        << " in the map: the " << (options.keep_newest ? "newest " : "oldest ") << options.keep_per_place << " per place of " << options.place_size << " m and "
        << options.heading_sectors << " headings kept, the others marginalised into them)\n"
        << "session_constraints=" << pruning.constraints_after << "  (of " << pruning.constraints_before << ")\n"
        << "session_loops_dropped=" << pruning.loops_dropped << "  (loop records of retired keyframes)\n"
        << "session_pruning_kl_nats=" << pruning.mean_kl << " mean, " << pruning.max_kl
        << " max  (per retired keyframe: what its tree of constraints lost against its dense marginal)\n"
        << "session_pruning_seconds=" << pruning.seconds << "\n";
  if (pruning.kept_unfactorizable > 0)
    lines << "session_kept_unfactorizable=" << pruning.kept_unfactorizable << "  (to retire, kept: their neighbourhood's information is singular)\n";
  return lines.str();
}

}  // namespace llc_tool
