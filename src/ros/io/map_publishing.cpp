#include "laser_loop_closure/ros/io/map_publishing.hpp"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl_conversions/pcl_conversions.h>

#include <cmath>

#include "laser_loop_closure/ros/io/msg_conversion.hpp"

namespace llc_ros {

nav_msgs::OccupancyGrid toOccupancyGridMsg(llc::OccupancyGrid grid, const std_msgs::Header& header) {
  nav_msgs::OccupancyGrid msg;
  msg.header = header;
  msg.info.map_load_time = header.stamp;
  msg.info.resolution = float(grid.resolution);
  msg.info.width = std::uint32_t(grid.width);
  msg.info.height = std::uint32_t(grid.height);
  msg.info.origin.position.x = grid.origin_x;
  msg.info.origin.position.y = grid.origin_y;
  msg.info.origin.orientation.w = 1.0;
  msg.data = std::move(grid.cells);
  return msg;
}

nav_msgs::Path toPathMsg(const std::vector<llc::Keyframe>& keyframes, const std::vector<llc::Pose2>& poses,
                         const std_msgs::Header& header) {
  nav_msgs::Path path;
  path.header = header;
  const std::size_t n = std::min(keyframes.size(), poses.size());
  path.poses.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    path.poses[k].header.frame_id = header.frame_id;
    path.poses[k].header.stamp.fromSec(keyframes[k].stamp);
    path.poses[k].pose = toPoseMsg(poses[k]);
  }
  return path;
}

sensor_msgs::PointCloud2 toCloudMsg(const std::vector<const llc::Scan*>& scans, const std::vector<llc::Pose2>& poses,
                                    double max_range, double voxel_size, const std_msgs::Header& header) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  const std::size_t n = std::min(scans.size(), poses.size());
  for (std::size_t k = 0; k < n; ++k) {
    const llc::Scan& scan = *scans[k];
    const double c = std::cos(poses[k].theta), s = std::sin(poses[k].theta);
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const double r = scan.ranges[i];
      if (!std::isfinite(r) || r <= 0.0 || r >= max_range) continue;
      const double bx = r * std::cos(scan.bearings[i]), by = r * std::sin(scan.bearings[i]);
      cloud->push_back(pcl::PointXYZ(float(poses[k].x + c * bx - s * by), float(poses[k].y + s * bx + c * by), 0.0f));
    }
  }
  pcl::PointCloud<pcl::PointXYZ> output;
  if (voxel_size > 0.0 && !cloud->empty()) {
    pcl::VoxelGrid<pcl::PointXYZ> voxels;
    voxels.setInputCloud(cloud);
    voxels.setLeafSize(float(voxel_size), float(voxel_size), float(voxel_size));
    voxels.filter(output);
  } else {
    output = *cloud;
  }
  sensor_msgs::PointCloud2 msg;
  pcl::toROSMsg(output, msg);
  msg.header = header;
  return msg;
}

namespace {

visualization_msgs::Marker lineList(const std_msgs::Header& header, const std::string& ns, double width, float r, float g,
                                    float b, float a) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = 0;
  m.type = visualization_msgs::Marker::LINE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.color.r = r, m.color.g = g, m.color.b = b, m.color.a = a;
  return m;
}

geometry_msgs::Point point(const llc::Pose2& p) {
  geometry_msgs::Point q;
  q.x = p.x, q.y = p.y;
  return q;
}

}  // namespace

visualization_msgs::MarkerArray graphMarkers(const std::vector<llc::Pose2>& poses,
                                             const std::vector<llc::LoopRecord>& loops, const std_msgs::Header& header) {
  return graphMarkers(poses, loops, header, FleetGraph{});
}

bool saveMapOf(const std::vector<std::shared_ptr<const llc::CompactScan>>& scans, const std::vector<llc::Pose2>& poses,
               const llc::OccupancyGridOptions& options, const std::string& stem, std::string* message) {
  if (scans.empty()) {
    *message = "no keyframe yet: nothing to save";
    return false;
  }
  try {
    llc::saveMapFiles(llc::buildOccupancyGrid(scans, poses, options), stem, options);
  } catch (const std::exception& e) {
    *message = e.what();
    return false;
  }
  *message = "wrote " + stem + ".pgm and " + stem + ".yaml";
  return true;
}

visualization_msgs::MarkerArray graphMarkers(const std::vector<llc::Pose2>& poses, const std::vector<llc::LoopRecord>& loops,
                                             const std_msgs::Header& header, const FleetGraph& fleet) {
  visualization_msgs::Marker nodes;
  nodes.header = header;
  nodes.ns = "keyframes";
  nodes.type = visualization_msgs::Marker::SPHERE_LIST;
  nodes.action = visualization_msgs::Marker::ADD;
  nodes.pose.orientation.w = 1.0;
  nodes.scale.x = nodes.scale.y = nodes.scale.z = 0.15;
  nodes.color.r = 0.1f, nodes.color.g = 0.3f, nodes.color.b = 0.9f, nodes.color.a = 1.0f;
  visualization_msgs::Marker odometry = lineList(header, "odometry", 0.04, 0.1f, 0.3f, 0.9f, 0.8f);
  visualization_msgs::Marker applied = lineList(header, "loops_applied", 0.1, 0.0f, 0.8f, 0.0f, 1.0f);
  visualization_msgs::Marker by_consensus = lineList(header, "loops_applied_by_consensus", 0.1, 1.0f, 0.55f, 0.0f, 1.0f);
  visualization_msgs::Marker gated = lineList(header, "loops_refused_by_gate", 0.1, 0.9f, 0.0f, 0.0f, 1.0f);
  visualization_msgs::Marker aligned = lineList(header, "loops_refused_by_alignment", 0.02, 0.5f, 0.5f, 0.5f, 0.5f);
  visualization_msgs::Marker cross = lineList(header, "cross_robot_loops", 0.15, 0.9f, 0.0f, 0.9f, 1.0f);
  // A loop joins two poses less than a few metres apart: at the scale of a whole map its line
  // is a dot, so the newer pose of each loop is also marked by a disc that stays visible.
  visualization_msgs::Marker applied_places = applied, gated_places = gated, cross_places = cross;
  for (visualization_msgs::Marker* m : {&applied_places, &gated_places, &cross_places}) {
    m->ns = m == &applied_places ? "loop_places_applied" : m == &gated_places ? "loop_places_refused_by_gate"
                                                                              : "cross_robot_loop_places";
    m->type = visualization_msgs::Marker::SPHERE_LIST;
    m->scale.x = m->scale.y = 2.0, m->scale.z = 0.05;
    m->color.a = 0.6f;
  }
  const bool several = fleet.previous.size() == poses.size() && fleet.robot.size() == poses.size();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    nodes.points.push_back(point(poses[k]));
    const std::size_t previous = several ? fleet.previous[k] : k - 1;
    if (k > 0 && previous != k && previous < poses.size()) {
      odometry.points.push_back(point(poses[previous]));
      odometry.points.push_back(point(poses[k]));
    }
  }
  for (const llc::LoopRecord& record : loops) {
    if (record.loop.from >= poses.size() || record.loop.to >= poses.size()) continue;
    const bool between_robots = several && fleet.robot[record.loop.from] != fleet.robot[record.loop.to];
    visualization_msgs::Marker& m = record.applied && between_robots ? cross
                                    : record.by_consensus            ? by_consensus
                                    : record.applied                 ? applied
                                    : record.loop.accepted           ? gated
                                                                     : aligned;
    m.points.push_back(point(poses[record.loop.from]));
    m.points.push_back(point(poses[record.loop.to]));
    if (record.loop.accepted)
      (record.applied ? (between_robots ? cross_places : applied_places) : gated_places).points.push_back(point(poses[record.loop.to]));
  }
  visualization_msgs::MarkerArray array;
  std::vector<visualization_msgs::Marker*> markers{&nodes,   &odometry,       &applied,      &by_consensus, &gated,
                                                   &aligned, &applied_places, &gated_places};
  if (several) markers.insert(markers.end(), {&cross, &cross_places});
  for (visualization_msgs::Marker* m : markers) {
    // rviz refuses an empty LINE_LIST/SPHERE_LIST with a warning; DELETE keeps it quiet.
    if (m->points.empty()) m->action = visualization_msgs::Marker::DELETE;
    array.markers.push_back(*m);
  }
  return array;
}

}  // namespace llc_ros
