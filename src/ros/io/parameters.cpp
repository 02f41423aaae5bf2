#include "laser_loop_closure/ros/io/parameters.hpp"

#include <algorithm>

#include <ros/console.h>
#include <ros/param.h>

namespace llc_ros {

template <class T>
void ParameterReader::read(const std::string& name, T& value, const char* type) {
  names_.push_back(name);
  if (!error_.empty() || !nh_.hasParam(name)) return;
  T read_value;
  if (!nh_.getParam(name, read_value)) {
    error_ = "parameter " + nh_.resolveName(name) + " is not a " + type;
    return;
  }
  value = read_value;
}

void ParameterReader::operator()(const std::string& name, double& value) { read(name, value, "number"); }
void ParameterReader::operator()(const std::string& name, int& value) { read(name, value, "integer"); }
void ParameterReader::operator()(const std::string& name, bool& value) { read(name, value, "boolean"); }
void ParameterReader::operator()(const std::string& name, std::string& value) { read(name, value, "string"); }
void ParameterReader::operator()(const std::string& name, std::size_t& value) {
  int as_int = int(value);
  read(name, as_int, "integer");
  if (!error_.empty()) return;
  if (as_int < 0) {
    error_ = "parameter " + nh_.resolveName(name) + " must not be negative";
    return;
  }
  value = std::size_t(as_int);
}

std::vector<std::string> unknownParameters(const ros::NodeHandle& nh, const std::vector<std::string>& known) {
  std::vector<std::string> all, unknown;
  if (!ros::param::getParamNames(all)) return unknown;
  std::string prefix = nh.getNamespace();
  if (prefix.empty() || prefix.back() != '/') prefix += '/';
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string relative = name.substr(prefix.size());
    if (std::find(known.begin(), known.end(), relative) == known.end()) unknown.push_back(relative);
  }
  return unknown;
}

void warnUnknownParameters(const ros::NodeHandle& nh, const std::string& node, const std::vector<std::string>& known) {
  for (const std::string& unknown : unknownParameters(nh, known)) {
    const std::string note = llc::retiredParameterNote(unknown);
    const std::string hint = note.empty() ? "" : " (" + note + ")";
    ROS_WARN("%s: parameter %s/%s is not one of mine; ignored%s", node.c_str(), nh.getNamespace().c_str(), unknown.c_str(),
             hint.c_str());
  }
}

bool readSystemOptions(const ros::NodeHandle& nh, llc::SystemOptions* options, std::vector<std::string>* names,
                       std::string* error) {
  return readParameters(
      nh, options, [](llc::SystemOptions& o, ParameterReader& reader) { llc::visitParameters(o, reader); }, names,
      error);
}

}  // namespace llc_ros
