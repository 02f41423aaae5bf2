// /map kept up to date by parts: the back ends' occupancy grid (llc::IncrementalOccupancyGrid)
// published whole on /map (latched, and to each new subscriber) and by its changed parts on /map_updates, as rviz's map
// display and costmap_2d's static layer read them.
#pragma once

#include <atomic>
#include <memory>
#include <vector>

#include <map_msgs/OccupancyGridUpdate.h>
#include <ros/ros.h>
#include <std_msgs/Header.h>

#include "laser_loop_closure/core/map/incremental_grid.hpp"

namespace llc_ros {

map_msgs::OccupancyGridUpdate toOccupancyGridUpdateMsg(llc::OccupancyGrid part, const llc::CellBox& box,
                                                       const llc::CellBox& whole, const std_msgs::Header& header);

class MapUpdatePublisher {
 public:
  /// Advertises map (latched when `latch`) and map_updates on nh. Throws std::invalid_argument
  /// on bad options.
  MapUpdatePublisher(ros::NodeHandle nh, const llc::OccupancyGridOptions& options, bool latch);

  struct Published {
    llc::GridUpdateResult update;
    bool whole = false;       ///< /map was sent whole (bounds grew, first time, or a new subscriber)
    std::size_t parts = 0;    ///< map_updates messages sent
  };
  /// Draws what changed (at most max_draws_per_update keyframes) and publishes it. Throws
  /// std::invalid_argument when the sizes differ.
  Published publish(const std::vector<std::shared_ptr<const llc::CompactScan>>& scans, const std::vector<llc::Pose2>& poses,
                    const std_msgs::Header& header);
  /// Someone subscribed to /map since it was last sent whole.
  bool wholeDue() const { return whole_due_; }
  std::size_t bytes() const { return grid_.bytes(); }

 private:
  llc::OccupancyGridOptions options_;
  llc::IncrementalOccupancyGrid grid_;
  ros::Publisher map_pub_, update_pub_;
  std::atomic<bool> whole_due_{true};
};

}  // namespace llc_ros
