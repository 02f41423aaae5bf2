// ROS parameters, read in one place: every nodelet reads its options here through the same
// name lists the core and `llc slam --config` use (slam_parameters.hpp), so a parameter's ROS
// name is the option's field name, nested by stage like config/slam.yaml.
#pragma once

#include <ros/node_handle.h>

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/slam/slam_parameters.hpp"

namespace llc_ros {

/// Reads a parameter when it is set; keeps the default when not. Records the first problem
/// (a value of the wrong type, a negative count) in error() naming the parameter.
class ParameterReader {
 public:
  explicit ParameterReader(const ros::NodeHandle& nh) : nh_(nh) {}
  void operator()(const std::string& name, double& value);
  void operator()(const std::string& name, int& value);
  void operator()(const std::string& name, bool& value);
  void operator()(const std::string& name, std::size_t& value);
  void operator()(const std::string& name, std::string& value);
  const std::string& error() const { return error_; }
  /// Every name visited, for unknownParameters().
  const std::vector<std::string>& names() const { return names_; }

 private:
  template <class T>
  void read(const std::string& name, T& value, const char* type);
  const ros::NodeHandle& nh_;
  std::string error_;
  std::vector<std::string> names_;
};

/// Parameters set under nh's namespace that no one reads (typos, old names), relative to it.
std::vector<std::string> unknownParameters(const ros::NodeHandle& nh, const std::vector<std::string>& known);

/// Reads options with `visit(reader)`, then warns once about parameters under nh that nothing
/// read. False with a message naming the parameter on a bad value or failed validation.
template <class Options, class Visit>
bool readParameters(const ros::NodeHandle& nh, Options* options, Visit&& visit, std::vector<std::string>* names,
                    std::string* error) {
  ParameterReader reader(nh);
  visit(*options, reader);
  if (!reader.error().empty()) {
    *error = reader.error();
    return false;
  }
  const std::string invalid = options->validate();
  if (!invalid.empty()) {
    *error = nh.getNamespace() + ": " + invalid;
    return false;
  }
  if (names) names->insert(names->end(), reader.names().begin(), reader.names().end());
  return true;
}

/// The SLAM options (odometry/..., loops/..., aligner/..., esdf/..., map/...) under nh.
bool readSystemOptions(const ros::NodeHandle& nh, llc::SystemOptions* options, std::vector<std::string>* names,
                       std::string* error);

/// Logs a warning for each parameter under nh that is not among `known`.
void warnUnknownParameters(const ros::NodeHandle& nh, const std::string& node, const std::vector<std::string>& known);

/// What a nodelet reads at start: its own options (through visit) and, when `system` is given,
/// the SLAM options too. Warns about parameters no one reads; throws std::runtime_error
/// "<node>: <problem>" on a bad value.
template <class Options, class Visit>
void loadNodeParameters(const ros::NodeHandle& nh, const std::string& node, Options* options, Visit&& visit,
                        llc::SystemOptions* system = nullptr) {
  std::string error;
  std::vector<std::string> names;
  if (!readParameters(nh, options, visit, &names, &error) || (system && !readSystemOptions(nh, system, &names, &error)))
    throw std::runtime_error(node + ": " + error);
  warnUnknownParameters(nh, node, names);
}

}  // namespace llc_ros
