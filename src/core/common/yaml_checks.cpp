#include "laser_loop_closure/core/common/yaml_checks.hpp"

#include <map>

namespace llc {

std::string repeatedYamlKey(const YAML::Node& node) {
  if (node.IsSequence()) {
    for (const YAML::Node& item : node) {
      const std::string found = repeatedYamlKey(item);
      if (!found.empty()) return found;
    }
  } else if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (const auto& entry : node) {
      if (entry.first.IsScalar()) {
        const int line = entry.first.Mark().line + 1;
        const auto [it, inserted] = first_line.emplace(entry.first.Scalar(), line);
        if (!inserted)
          return "line " + std::to_string(line) + ": key '" + entry.first.Scalar() + "' is repeated (first on line " +
                 std::to_string(it->second) + ")";
      }
      const std::string found = repeatedYamlKey(entry.second);
      if (!found.empty()) return found;
    }
  }
  return "";
}

}  // namespace llc
