// The graph markers rviz shows (graphMarkers): each loop in the namespace of what became of it,
// and an empty namespace deleted rather than sent empty (rviz warns about an empty list).
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "laser_loop_closure/ros/io/map_publishing.hpp"

namespace {

llc::LoopRecord recordOf(std::size_t from, std::size_t to, bool accepted, bool applied, bool by_consensus) {
  llc::LoopRecord record;
  record.loop.from = from, record.loop.to = to, record.loop.accepted = accepted;
  record.applied = applied, record.by_consensus = by_consensus;
  return record;
}

std::map<std::string, visualization_msgs::Marker> byNamespace(const visualization_msgs::MarkerArray& array) {
  std::map<std::string, visualization_msgs::Marker> found;
  for (const visualization_msgs::Marker& m : array.markers) {
    EXPECT_EQ(found.count(m.ns), 0u) << "namespace twice: " << m.ns;
    found[m.ns] = m;
  }
  return found;
}

TEST(GraphMarkers, EachLoopIsDrawnInTheNamespaceOfWhatBecameOfIt) {
  const std::vector<llc::Pose2> poses = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}};
  std::vector<llc::LoopRecord> loops = {
      recordOf(0, 2, true, true, false),   // applied
      recordOf(0, 3, true, true, true),    // applied by consensus
      recordOf(1, 3, true, true, true),    // applied by consensus
      recordOf(1, 4, true, false, false),  // refused by the gate
      recordOf(2, 4, false, false, false), // refused by alignment
      recordOf(0, 9, true, true, false),   // names a keyframe not there: left out
  };
  std_msgs::Header header;
  header.frame_id = "map";
  const auto markers = byNamespace(llc_ros::graphMarkers(poses, loops, header));
  ASSERT_EQ(markers.size(), 8u);
  const auto lines = [&](const std::string& ns) { return markers.at(ns).points.size() / 2; };
  EXPECT_EQ(markers.at("keyframes").points.size(), 5u);
  EXPECT_EQ(lines("odometry"), 4u);
  EXPECT_EQ(lines("loops_applied"), 1u);
  EXPECT_EQ(lines("loops_applied_by_consensus"), 2u);
  EXPECT_EQ(lines("loops_refused_by_gate"), 1u);
  EXPECT_EQ(lines("loops_refused_by_alignment"), 1u);
  EXPECT_EQ(markers.at("loop_places_applied").points.size(), 3u);  // a disc for every applied loop
  EXPECT_EQ(markers.at("loop_places_refused_by_gate").points.size(), 1u);
  const visualization_msgs::Marker& orange = markers.at("loops_applied_by_consensus");
  EXPECT_EQ(orange.points[0].x, 0.0);
  EXPECT_EQ(orange.points[1].x, 3.0);
  EXPECT_GT(orange.color.r, orange.color.b);
  EXPECT_NE(orange.color.g, markers.at("loops_applied").color.g);
  for (const auto& named : markers) {
    EXPECT_EQ(named.second.action, visualization_msgs::Marker::ADD) << named.first;
    EXPECT_EQ(named.second.header.frame_id, "map");
  }

  // None by consensus: that namespace is deleted, not sent empty.
  loops = {recordOf(0, 2, true, true, false)};
  const auto plain = byNamespace(llc_ros::graphMarkers(poses, loops, header));
  EXPECT_EQ(plain.at("loops_applied_by_consensus").action, visualization_msgs::Marker::DELETE);
  EXPECT_EQ(plain.at("loops_applied").action, visualization_msgs::Marker::ADD);
}

TEST(GraphMarkers, SeveralRobotsEachHaveTheirOwnChainAndTheirLoopsTheirOwnColour) {
  // Keyframes 0, 1 and 4 of robot 0, 2 and 3 of robot 1 (map order: as they entered).
  const std::vector<llc::Pose2> poses = {{0, 0, 0}, {1, 0, 0}, {5, 5, 0}, {6, 5, 0}, {2, 0, 0}};
  llc_ros::FleetGraph fleet;
  fleet.robot = {0, 0, 1, 1, 0};
  fleet.previous = {0, 0, 2, 2, 1};
  const std::vector<llc::LoopRecord> loops = {
      recordOf(0, 4, true, true, false),   // robot 0's own
      recordOf(1, 3, true, true, false),   // between the robots
      recordOf(0, 2, true, false, false),  // between the robots, refused by the gate
  };
  std_msgs::Header header;
  const auto markers = byNamespace(llc_ros::graphMarkers(poses, loops, header, fleet));
  ASSERT_EQ(markers.size(), 10u);
  const auto& odometry = markers.at("odometry").points;
  ASSERT_EQ(odometry.size(), 6u);  // 0-1, 2-3, 1-4: no line from one robot to the other
  EXPECT_EQ(odometry[2].x, 5.0);
  EXPECT_EQ(odometry[3].x, 6.0);
  EXPECT_EQ(odometry[4].x, 1.0);
  EXPECT_EQ(odometry[5].x, 2.0);
  EXPECT_EQ(markers.at("loops_applied").points.size(), 2u);
  EXPECT_EQ(markers.at("cross_robot_loops").points.size(), 2u);
  EXPECT_EQ(markers.at("cross_robot_loop_places").points.size(), 1u);
  EXPECT_EQ(markers.at("loops_refused_by_gate").points.size(), 2u);
  const auto& cross = markers.at("cross_robot_loops");
  EXPECT_GT(cross.color.r, cross.color.g);  // magenta, unlike any other loop
  EXPECT_GT(cross.color.b, cross.color.g);
}

}  // namespace
