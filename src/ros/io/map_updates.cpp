#include "laser_loop_closure/ros/io/map_updates.hpp"

#include "laser_loop_closure/ros/io/map_publishing.hpp"

namespace llc_ros {

map_msgs::OccupancyGridUpdate toOccupancyGridUpdateMsg(llc::OccupancyGrid part, const llc::CellBox& box,
                                                       const llc::CellBox& whole, const std_msgs::Header& header) {
  map_msgs::OccupancyGridUpdate msg;
  msg.header = header;
  msg.x = std::int32_t(box.col - whole.col);  // cells from the corner of the /map last sent whole
  msg.y = std::int32_t(box.row - whole.row);
  msg.width = std::uint32_t(part.width);
  msg.height = std::uint32_t(part.height);
  msg.data = std::move(part.cells);
  return msg;
}

MapUpdatePublisher::MapUpdatePublisher(ros::NodeHandle nh, const llc::OccupancyGridOptions& options, bool latch)
    : options_(options), grid_(options) {
  // A new subscriber to /map gets it whole at the next update, made then: the latched one may be
  // older than the parts sent since. (Another subscriber in a process that already has one
  // makes no new connection: it gets the latched one, or, unlatched, waits for the next whole.)
  map_pub_ = nh.advertise<nav_msgs::OccupancyGrid>(
      "map", 1, [this](const ros::SingleSubscriberPublisher&) { whole_due_ = true; }, ros::SubscriberStatusCallback(),
      ros::VoidConstPtr(), latch);
  // Parts come in bursts after a loop moves many keyframes: a deep queue loses none.
  update_pub_ = nh.advertise<map_msgs::OccupancyGridUpdate>("map_updates", 1000);
}

MapUpdatePublisher::Published MapUpdatePublisher::publish(const std::vector<std::shared_ptr<const llc::CompactScan>>& scans,
                                                          const std::vector<llc::Pose2>& poses,
                                                          const std_msgs::Header& header) {
  Published published;
  published.update = grid_.update(scans, poses, std::size_t(options_.max_draws_per_update));
  const llc::CellBox whole = grid_.bounds();
  if (whole.empty()) return published;
  if (whole_due_.exchange(false) || published.update.bounds_grew) {
    map_pub_.publish(toOccupancyGridMsg(grid_.region(whole), header));
    published.whole = true;
    return published;
  }
  for (const llc::CellBox& box : published.update.changed) {
    update_pub_.publish(toOccupancyGridUpdateMsg(grid_.region(box), box, whole, header));
    ++published.parts;
  }
  return published;
}

}  // namespace llc_ros
