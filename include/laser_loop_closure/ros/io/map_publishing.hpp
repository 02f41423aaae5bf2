// What the back end publishes, built from core results: free functions, no state.
#pragma once

#include <memory>
#include <string>

#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <vector>

#include "laser_loop_closure/core/map/occupancy_grid.hpp"
#include "laser_loop_closure/core/slam/slam_types.hpp"

namespace llc_ros {

/// Takes the grid by value: a whole map of 10^8 cells is moved into the message, not copied.
nav_msgs::OccupancyGrid toOccupancyGridMsg(llc::OccupancyGrid grid, const std_msgs::Header& header);

/// One pose per keyframe, stamped with the keyframe's stamp.
nav_msgs::Path toPathMsg(const std::vector<llc::Keyframe>& keyframes, const std::vector<llc::Pose2>& poses,
                         const std_msgs::Header& header);

/// Every keyframe's returns (finite ranges below max_range) at its pose, thinned by PCL's
/// VoxelGrid to one point per voxel_size cube (0: every point).
sensor_msgs::PointCloud2 toCloudMsg(const std::vector<const llc::Scan*>& scans, const std::vector<llc::Pose2>& poses,
                                    double max_range, double voxel_size, const std_msgs::Header& header);

/// The graph: keyframes (dots), odometry chain (blue), applied loops (green), loops the gate
/// refused and a consensus applied later (orange), loops refused by the chi-square gate (red),
/// candidates refused by alignment (grey), and a 2 m disc at the newer pose of each loop so that
/// loops show at the scale of a whole map. Namespaces: keyframes, odometry, loops_applied,
/// loops_applied_by_consensus, loops_refused_by_gate, loops_refused_by_alignment,
/// loop_places_applied, loop_places_refused_by_gate.
visualization_msgs::MarkerArray graphMarkers(const std::vector<llc::Pose2>& poses,
                                             const std::vector<llc::LoopRecord>& loops, const std_msgs::Header& header);

/// ~save_map's work, shared by the back ends: the occupancy grid of `scans` at `poses` saved as
/// stem.pgm and stem.yaml (llc::saveMapFiles). True with what was written in *message, or false
/// with why not (no keyframe yet, or the write failed).
bool saveMapOf(const std::vector<std::shared_ptr<const llc::CompactScan>>& scans, const std::vector<llc::Pose2>& poses,
               const llc::OccupancyGridOptions& options, const std::string& stem, std::string* message);

/// A graph of several robots' keyframes (one map): keyframe k's odometry line runs from
/// previous[k] (previous[k] == k: the first of its robot's chain, no line), and an applied loop
/// between two robots (robot[from] != robot[to]) is drawn in its own colour (magenta, namespace
/// cross_robot_loops, a 2 m disc at its newer pose in cross_robot_loop_places); the rest as above.
struct FleetGraph {
  std::vector<std::size_t> previous;  ///< per keyframe
  std::vector<std::size_t> robot;     ///< per keyframe
};
visualization_msgs::MarkerArray graphMarkers(const std::vector<llc::Pose2>& poses, const std::vector<llc::LoopRecord>& loops,
                                             const std_msgs::Header& header, const FleetGraph& fleet);

}  // namespace llc_ros
