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

}  // namespace
