#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/common/yaml_checks.hpp"

#include "laser_loop_closure/core/common/file_util.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace llc {
namespace {

constexpr double kMaxStumpAlpha = 745.0;  // see the check in the reader

const char* kFormat = "laser_loop_closure/classifier";

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw ModelError("classifier model " + path + ": " + why);
}

template <typename T>
T required(const YAML::Node& node, const char* key, const std::string& path,
           const std::string& where) {
  const YAML::Node value = node[key];
  if (!value) refuse(path, "missing '" + std::string(key) + "' in " + where + " (truncated?)");
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    refuse(path, "'" + std::string(key) + "' in " + where + " has the wrong type");
  }
}

std::string describeDifference(const FeatureOptions& file, const FeatureOptions& wanted) {
  std::ostringstream why;
  auto diff = [&](const char* name, auto a, auto b) {
    if (a != b) why << " " << name << " " << a << " (model) vs " << b << " (configured);";
  };
  diff("r_max", file.r_max, wanted.r_max);
  diff("g_max_dist", file.g_max_dist, wanted.g_max_dist);
  diff("g_min_size", file.g_min_size, wanted.g_min_size);
  diff("closed_ring", file.closed_ring, wanted.closed_ring);
  diff("feature_set", toString(file.feature_set), toString(wanted.feature_set));
  return why.str();
}

}  // namespace

void saveClassifierModel(const ClassifierModel& model, const std::string& path) {
  const FeatureOptions& f = model.features;
  const std::vector<std::string>& names = pairFeatureNames(f.feature_set);
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // exact round trip of every double
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kFormat;
  out << YAML::Key << "version" << YAML::Value << kClassifierModelVersion;
  out << YAML::Key << "features" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "set" << YAML::Value << toString(f.feature_set);
  out << YAML::Key << "r_max" << YAML::Value << f.r_max;
  out << YAML::Key << "g_max_dist" << YAML::Value << f.g_max_dist;
  out << YAML::Key << "g_min_size" << YAML::Value << f.g_min_size;
  out << YAML::Key << "closed_ring" << YAML::Value << f.closed_ring;
  out << YAML::Key << "names" << YAML::Value << YAML::Flow << names;
  out << YAML::EndMap;
  out << YAML::Key << "threshold_k" << YAML::Value << model.classifier.thresholdK();
  out << YAML::Key << "rounds" << YAML::Value << model.classifier.stumps().size();
  out << YAML::Key << "stumps" << YAML::Value << YAML::BeginSeq;
  for (const Stump& s : model.classifier.stumps()) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "feature" << YAML::Value << s.feature;
    out << YAML::Key << "name" << YAML::Value
        << (std::size_t(s.feature) < names.size() ? names[std::size_t(s.feature)] : "?");
    out << YAML::Key << "polarity" << YAML::Value << s.polarity;
    out << YAML::Key << "threshold" << YAML::Value << s.threshold;
    out << YAML::Key << "alpha" << YAML::Value << s.alpha;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!model.provenance.empty()) {
    out << YAML::Key << "provenance" << YAML::Value << YAML::BeginMap;
    for (const auto& [key, value] : model.provenance) out << YAML::Key << key << YAML::Value << value;
    out << YAML::EndMap;
  }
  out << YAML::Key << "end" << YAML::Value << "laser_loop_closure/classifier";
  out << YAML::EndMap;

  std::ostringstream text;
  text << "# laser_loop_closure classifier model; see docs/file_formats.md, 'Model file'.\n" << out.c_str() << "\n";
  try {
    writeFileAtomically(path, text.str());
  } catch (const std::runtime_error& e) {
    throw ModelError("classifier model " + path + ": " + e.what());
  }
}

ClassifierModel loadClassifierModel(const std::string& path, const FeatureOptions* expected) {
  std::ifstream file(path);
  if (!file) refuse(path, "cannot open the file");
  YAML::Node root;
  try {
    root = YAML::Load(file);
  } catch (const YAML::Exception& e) {
    refuse(path, std::string("not valid YAML (") + e.what() + ")");
  }
  if (!root.IsMap()) refuse(path, "not a classifier model (expected a YAML map)");
  const std::string repeated = repeatedYamlKey(root);
  if (!repeated.empty()) refuse(path, repeated);
  if (!root["format"] || root["format"].as<std::string>("") != kFormat)
    refuse(path, std::string("not a classifier model (format is not '") + kFormat + "')");
  const int version = required<int>(root, "version", path, "the file");
  if (version != kClassifierModelVersion)
    refuse(path, "version " + std::to_string(version) + " is not supported (this build reads " +
                     std::to_string(kClassifierModelVersion) + ")");
  // The end marker is written last: without it the file was cut short.
  if (!root["end"] || root["end"].as<std::string>("") != kFormat)
    refuse(path, "the end marker is missing (truncated file?)");

  ClassifierModel model;
  const YAML::Node features = root["features"];
  if (!features || !features.IsMap()) refuse(path, "missing the 'features' block");
  const std::string set = required<std::string>(features, "set", path, "features");
  if (!parseFeatureSet(set, &model.features.feature_set))
    refuse(path, "unknown feature set '" + set + "'");
  model.features.r_max = required<double>(features, "r_max", path, "features");
  model.features.g_max_dist = required<double>(features, "g_max_dist", path, "features");
  model.features.g_min_size = required<int>(features, "g_min_size", path, "features");
  model.features.closed_ring = required<bool>(features, "closed_ring", path, "features");
  const std::string invalid = model.features.validate();
  if (!invalid.empty()) refuse(path, "feature parameters: " + invalid);
  const auto names = required<std::vector<std::string>>(features, "names", path, "features");
  if (names != pairFeatureNames(model.features.feature_set))
    refuse(path, "its feature names differ from this build's '" + set +
                     "' features (made by another version of the features?)");
  if (expected && *expected != model.features)
    refuse(path, "made with other feature parameters:" + describeDifference(model.features, *expected));

  const double k = required<double>(root, "threshold_k", path, "the file");
  if (!(k >= 0.0 && k <= 1.0)) refuse(path, "threshold_k must lie in [0, 1]");
  const std::size_t rounds = required<std::size_t>(root, "rounds", path, "the file");
  const YAML::Node stumps = root["stumps"];
  if (!stumps || !stumps.IsSequence()) refuse(path, "missing the 'stumps' list");
  if (stumps.size() != rounds)
    refuse(path, "'rounds' says " + std::to_string(rounds) + " stumps but the file has " +
                     std::to_string(stumps.size()) + " (truncated?)");
  std::vector<Stump> parsed;
  for (std::size_t i = 0; i < stumps.size(); ++i) {
    const std::string where = "stump " + std::to_string(i);
    Stump s;
    s.feature = required<int>(stumps[i], "feature", path, where);
    s.polarity = required<int>(stumps[i], "polarity", path, where);
    s.threshold = required<double>(stumps[i], "threshold", path, where);
    s.alpha = required<double>(stumps[i], "alpha", path, where);
    if (s.feature < 0 || std::size_t(s.feature) >= names.size())
      refuse(path, where + ": feature index " + std::to_string(s.feature) + " out of range");
    if (stumps[i]["name"] && stumps[i]["name"].as<std::string>("") != names[std::size_t(s.feature)])
      refuse(path, where + ": name does not match feature " + std::to_string(s.feature));
    if (s.polarity != 1 && s.polarity != -1) refuse(path, where + ": polarity must be 1 or -1");
    if (!std::isfinite(s.threshold)) refuse(path, where + ": threshold is not finite");
    if (!(std::isfinite(s.alpha) && s.alpha >= 0.0))
      refuse(path, where + ": alpha must be finite and not negative");
    // AdaBoost's alpha is log((1 - e) / e) for a weighted error e a double can hold: at most
    // log(1 / 4.9e-324) = 744.4. More was not trained; it would outvote every other stump.
    if (s.alpha > kMaxStumpAlpha)
      refuse(path, where + ": alpha " + stumps[i]["alpha"].as<std::string>("") + " above " + std::to_string(int(kMaxStumpAlpha)) +
                       ", more than any training gives");
    parsed.push_back(s);
  }
  double total_alpha = 0.0;
  for (const Stump& stump : parsed) total_alpha += stump.alpha;
  if (!(total_alpha > 0.0))
    refuse(path, "no stump has a positive alpha (rounds: " + std::to_string(rounds) +
                     "): such a model cannot tell one place from another");
  model.classifier = StrongClassifier(std::move(parsed), k);
  if (const YAML::Node provenance = root["provenance"]; provenance && provenance.IsMap())
    for (const auto& entry : provenance)
      model.provenance[entry.first.as<std::string>("")] = entry.second.as<std::string>("");
  return model;
}

}  // namespace llc
