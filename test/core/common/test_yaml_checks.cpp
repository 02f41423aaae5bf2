// A YAML key written twice is refused with its line, at any depth; the project's readers refuse
// such files instead of taking the first value quietly.
#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>

#include "laser_loop_closure/core/common/yaml_checks.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "../test_util.hpp"

TEST(YamlChecks, NamesTheLineOfARepeatedKeyAtAnyDepth) {
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Load("a: 1\nb: 2\nc: [1, 2]\n")), "");
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Load("a: 1\nb: 2\na: 3\n")), "line 3: key 'a' is repeated (first on line 1)");
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Load("odometry:\n  x: 1\n  y: 2\n  x: 1\n")),
            "line 4: key 'x' is repeated (first on line 2)");
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Load("list:\n  - {k: 1, k: 2}\n")), "line 2: key 'k' is repeated (first on line 2)");
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Load("a:\n  b: 1\nc:\n  b: 1\n")), "") << "the same key in two maps is fine";
  EXPECT_EQ(llc::repeatedYamlKey(YAML::Node()), "");
}

TEST(YamlChecks, APipelineConfigWithARepeatedKeyIsRefused) {
  llc_test::TempDir dir;
  std::ofstream(dir.file("twice.yaml")) << "odometry:\n  keyframe_distance: 0.5\n  keyframe_distance: 2.0\n";
  llc::SystemOptions options;
  try {
    llc::loadSystemOptionsYaml(dir.file("twice.yaml"), &options);
    FAIL() << "a repeated key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 3: key 'keyframe_distance' is repeated"), std::string::npos) << e.what();
  }
}
