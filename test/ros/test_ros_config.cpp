// config/ros.yaml holds every ROS-side parameter of each nodelet at its code default, and
// nothing else (the SLAM parameters' file is checked the same way in test_core).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <limits>
#include <set>
#include <string>

#include "laser_loop_closure/ros/nodes/esdf_backend_ros.hpp"
#include "laser_loop_closure/ros/nodes/localization_ros.hpp"
#include "laser_loop_closure/ros/nodes/multi_robot_backend_ros.hpp"
#include "laser_loop_closure/ros/nodes/loop_closure_ros.hpp"
#include "laser_loop_closure/ros/nodes/scan_merger_ros.hpp"

namespace {

/// Compares each visited default with the YAML section's value; collects the names.
struct DefaultsMatch {
  YAML::Node section;
  std::set<std::string> names;
  template <class T>
  void operator()(const std::string& name, T& value) {
    names.insert(name);
    ASSERT_TRUE(section[name]) << name << " is missing from config/ros.yaml";
    EXPECT_EQ(section[name].as<T>(), value) << name;
  }
};

template <class Options, class Visit>
void checkSection(const YAML::Node& root, const std::string& node, Visit visit) {
  SCOPED_TRACE(node);
  ASSERT_TRUE(root[node]) << "no section " << node;
  Options defaults;
  EXPECT_EQ(defaults.validate(), "") << "the defaults must be valid";
  DefaultsMatch match{root[node], {}};
  visit(defaults, match);
  for (const auto& entry : root[node]) EXPECT_TRUE(match.names.count(entry.first.as<std::string>())) << entry.first.as<std::string>() << " is read by no one";
}

TEST(RosConfig, EveryParameterAtItsDefault) {
  const YAML::Node root = YAML::LoadFile(std::string(LLC_SOURCE_DIR) + "/config/ros.yaml");
  checkSection<llc_ros::ScanMergerOptions>(root, "scan_merger", [](auto& o, auto& v) { llc_ros::visitScanMergerParameters(o, v); });
  checkSection<llc_ros::LoopClosureNodeOptions>(root, "loop_closure", [](auto& o, auto& v) { llc_ros::visitLoopClosureParameters(o, v); });
  checkSection<llc_ros::EsdfBackendNodeOptions>(root, "esdf_backend", [](auto& o, auto& v) { llc_ros::visitEsdfBackendParameters(o, v); });
  checkSection<llc_ros::LocalizationNodeOptions>(root, "localization", [](auto& o, auto& v) { llc_ros::visitLocalizationParameters(o, v); });
  checkSection<llc_ros::MultiRobotBackendNodeOptions>(root, "multi_robot_backend",
                                                      [](auto& o, auto& v) { llc_ros::visitMultiRobotBackendParameters(o, v); });
  EXPECT_EQ(root.size(), 5u);
}

TEST(RosConfig, RobotNamesAreParsedOrRefused) {
  EXPECT_EQ(llc_ros::parseRobotNames("r1 r2  r3"), (std::vector<std::string>{"r1", "r2", "r3"}));
  EXPECT_EQ(llc_ros::parseRobotNames("alpha,beta"), (std::vector<std::string>{"alpha", "beta"}));
  EXPECT_THROW(llc_ros::parseRobotNames(""), std::invalid_argument);       // no robot
  EXPECT_THROW(llc_ros::parseRobotNames("r1 r1"), std::invalid_argument);  // one twice
  EXPECT_THROW(llc_ros::parseRobotNames("r1 9lives"), std::invalid_argument);  // not a ROS name
  llc_ros::MultiRobotBackendNodeOptions options;
  options.resend_wait = -1.0;
  EXPECT_NE(options.validate(), "");
  options = llc_ros::MultiRobotBackendNodeOptions{};
  options.queue_size = 0;
  EXPECT_NE(options.validate(), "");
}

TEST(RosConfig, BadOptionsAreRefused) {
  llc_ros::ScanMergerOptions merger;
  merger.back_timeout = 0.01;  // below max_pair_gap
  EXPECT_NE(merger.validate(), "");
  llc_ros::EsdfBackendNodeOptions backend;
  backend.odom_frame = backend.map_frame;
  EXPECT_NE(backend.validate(), "");
  for (const double step : {-0.001, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    backend = llc_ros::EsdfBackendNodeOptions{};
    backend.map_scan_step = step;
    EXPECT_NE(backend.validate(), "") << step;
    llc_ros::MultiRobotBackendNodeOptions fleet;
    fleet.map_scan_step = step;
    EXPECT_NE(fleet.validate(), "") << step;
  }
  backend.map_scan_step = 0.0;  // kept exact
  EXPECT_EQ(backend.validate(), "");
  llc_ros::LoopClosureNodeOptions loop;
  loop.input.max_lag = -1.0;
  EXPECT_NE(loop.validate(), "");
  loop = llc_ros::LoopClosureNodeOptions{};
  loop.input.tf_queue_size = 0;
  EXPECT_NE(loop.validate(), "");
  // Odometry after the scan's stamp may not be in tf yet when the scan passes its filter.
  for (const double offset : {0.05, -1.5, std::numeric_limits<double>::quiet_NaN()}) {
    loop = llc_ros::LoopClosureNodeOptions{};
    loop.input.odometry_time_offset = offset;
    EXPECT_NE(loop.validate(), "") << offset;
  }
  loop.input.odometry_time_offset = -0.2;
  EXPECT_EQ(loop.validate(), "");
  llc_ros::LocalizationNodeOptions localization;
  localization.map_frame = "/odom";  // tf1's spelling of odom_frame
  EXPECT_NE(localization.validate(), "");
  localization = llc_ros::LocalizationNodeOptions{};
  localization.hint_min_radius = 0.0;
  EXPECT_NE(localization.validate(), "");
  localization = llc_ros::LocalizationNodeOptions{};
  localization.input.queue_size = 0;  // the shared input part is checked too
  EXPECT_NE(localization.validate(), "");
}

}  // namespace
