// The newest diagnostics of one nodelet task, as a rostest reads them from /diagnostics
// (diagnostic_updater names a status "<node>: <task>", e.g. "llc_manager: loop closure").
#pragma once

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>

#include <cstdlib>
#include <map>
#include <mutex>
#include <string>

namespace llc_test {

class HealthWatch {
 public:
  HealthWatch(ros::NodeHandle& nh, const std::string& task) : suffix_(": " + task) {
    sub_ = nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 100, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
      for (const auto& status : m->status) {
        const std::string& name = status.name;
        if (name.size() < suffix_.size() || name.compare(name.size() - suffix_.size(), suffix_.size(), suffix_) != 0) continue;
        std::lock_guard<std::mutex> lock(mutex_);
        level_ = status.level;
        values_.clear();
        for (const auto& kv : status.values) values_[kv.key] = kv.value;
      }
    });
  }
  /// False until a status of the task has come.
  bool seen() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return !values_.empty();
  }
  /// The newest status's level (diagnostic_msgs::DiagnosticStatus::OK, WARN, ERROR); -1 before one.
  int level() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return values_.empty() ? -1 : int(level_);
  }
  /// A number among the newest status's values; -1 when it is not there.
  double value(const std::string& key) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = values_.find(key);
    return found == values_.end() ? -1.0 : std::atof(found->second.c_str());
  }

 private:
  std::string suffix_;
  mutable std::mutex mutex_;
  std::map<std::string, std::string> values_;
  unsigned char level_ = 0;
  ros::Subscriber sub_;
};

}  // namespace llc_test
