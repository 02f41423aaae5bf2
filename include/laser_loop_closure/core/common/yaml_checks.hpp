// yaml-cpp keeps every entry of a map, so a key written twice parses, and lookups quietly take
// the first: a file's reader refuses it instead (issue 62: a model with a key repeated a
// thousand times was accepted).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

namespace llc {

/// Empty when no map in `node`, at any depth, holds a key twice; else "line N: key 'K' is
/// repeated (first on line M)" (lines from 1).
[[nodiscard]] std::string repeatedYamlKey(const YAML::Node& node);

}  // namespace llc
