#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/core/common/yaml_checks.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <set>
#include <stdexcept>
#include <type_traits>

namespace llc {
namespace {

/// Flattens nested maps into "a/b/c" keys with their scalar nodes.
void flatten(const YAML::Node& node, const std::string& prefix, std::vector<std::pair<std::string, YAML::Node>>* out,
             const std::string& path) {
  if (!node.IsMap()) throw std::runtime_error(path + ": " + (prefix.empty() ? "the file" : prefix) + " must be a map");
  for (const auto& item : node) {
    const std::string key = prefix + item.first.as<std::string>();
    if (item.second.IsMap()) flatten(item.second, key + "/", out, path);
    else out->emplace_back(key, item.second);
  }
}

}  // namespace

std::string SystemOptions::validate() const {
  std::string error = slam.validate();
  if (!error.empty()) return error;
  error = map.validate();
  if (!error.empty()) return "map: " + error;
  error = localization.validate();
  if (!error.empty()) return "localization: " + error;
  error = multi_robot.validate();
  if (!error.empty()) return "multi_robot: " + error;
  error = lifelong.validate();
  return error.empty() ? "" : "lifelong: " + error;
}

std::vector<std::string> systemParameterNames() {
  std::vector<std::string> names;
  SystemOptions options;
  visitParameters(options, [&](const std::string& name, auto&) { names.push_back(name); });
  return names;
}

std::string retiredParameterNote(const std::string& name) {
  // Three margins, each on its own measure, became one choice among a step's seeds.
  static const std::set<std::string> folded_into_seed_gain{
      "odometry/track_min_fit_gain", "odometry/correlative_min_score_gain", "odometry/realign_min_fit_gain"};
  if (folded_into_seed_gain.count(name)) return "folded into odometry/seed_min_score_gain in 0.23.0";
  return "";
}

namespace {

/// Sets every named entry through the visitor (the same conversion for a file and the command
/// line); refuses an unknown name or a bad value naming `source`, then validates once.
void applyEntries(const std::vector<std::pair<std::string, YAML::Node>>& entries, const std::string& source,
                  SystemOptions* options) {
  std::set<std::string> known;
  for (const std::string& name : systemParameterNames()) known.insert(name);
  for (const auto& entry : entries)
    if (!known.count(entry.first)) {
      const std::string note = retiredParameterNote(entry.first);
      throw std::runtime_error(source + ": unknown parameter '" + entry.first + "'" + (note.empty() ? "" : " (" + note + ")"));
    }
  visitParameters(*options, [&](const std::string& name, auto& field) {
    using Field = std::decay_t<decltype(field)>;
    for (const auto& entry : entries) {
      if (entry.first != name) continue;
      try {
        if (!entry.second.IsScalar()) throw std::runtime_error("not a single value");
        if constexpr (std::is_same_v<Field, std::size_t>) {
          const long value = entry.second.as<long>();
          if (value < 0) throw std::runtime_error("must be >= 0");
          field = std::size_t(value);
        } else {
          field = entry.second.as<Field>();
        }
      } catch (const std::exception& e) {
        throw std::runtime_error(source + ": parameter '" + name + "': bad value (" + e.what() + ")");
      }
    }
  });
  const std::string error = options->validate();
  if (!error.empty()) throw std::runtime_error(source + ": " + error);
}

}  // namespace

void loadSystemOptionsYaml(const std::string& path, SystemOptions* options) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot read as YAML (" + e.what() + ")");
  }
  const std::string repeated = repeatedYamlKey(root);
  if (!repeated.empty()) throw std::runtime_error(path + ": " + repeated);
  std::vector<std::pair<std::string, YAML::Node>> entries;
  if (!root.IsNull()) flatten(root, "", &entries, path);
  applyEntries(entries, path, options);
}

void setSystemParameters(const std::vector<std::pair<std::string, std::string>>& values, const std::string& source,
                         SystemOptions* options) {
  std::vector<std::pair<std::string, YAML::Node>> entries;
  for (const auto& value : values) {
    YAML::Node node;
    try {
      node = YAML::Load(value.second);
    } catch (const std::exception& e) {
      throw std::runtime_error(source + ": parameter '" + value.first + "': bad value (" + e.what() + ")");
    }
    entries.emplace_back(value.first, node);
  }
  applyEntries(entries, source, options);
}

std::vector<std::pair<std::string, std::string>> systemParameterDefaults() {
  std::vector<std::pair<std::string, std::string>> out;
  SystemOptions options;
  visitParameters(options, [&](const std::string& name, auto& field) {
    using Field = std::decay_t<decltype(field)>;
    if constexpr (std::is_same_v<Field, bool>) {
      out.emplace_back(name, field ? "true" : "false");
    } else if constexpr (std::is_floating_point_v<Field>) {
      char text[32];
      std::snprintf(text, sizeof text, "%.15g", double(field));  // 0.35, not 0.34999999999999998
      out.emplace_back(name, text);
    } else {
      out.emplace_back(name, std::to_string(field));
    }
  });
  return out;
}

}  // namespace llc
