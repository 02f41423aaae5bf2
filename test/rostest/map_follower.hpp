// A /map subscriber that applies /map_updates the way rviz's map display does: the whole grid
// from /map, then each part written into it at its (x, y).
#pragma once

#include <map_msgs/OccupancyGridUpdate.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include <mutex>
#include <string>

namespace llc_test {

class MapFollower {
 public:
  explicit MapFollower(ros::NodeHandle nh, const std::string& topic = "/map") {
    whole_sub_ = nh.subscribe<nav_msgs::OccupancyGrid>(topic, 10, [this](const nav_msgs::OccupancyGrid::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      grid_ = *m;
      ++wholes_;
      last_ = ros::WallTime::now();
    });
    part_sub_ = nh.subscribe<map_msgs::OccupancyGridUpdate>(
        topic + "_updates", 10000, [this](const map_msgs::OccupancyGridUpdate::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          ++parts_;
          last_ = ros::WallTime::now();
          const std::size_t width = grid_.info.width, height = grid_.info.height;
          if (m->x < 0 || m->y < 0 || m->x + m->width > width || m->y + m->height > height ||
              m->data.size() != std::size_t(m->width) * m->height) {
            ++misfits_;  // rviz drops such a part
            return;
          }
          for (std::size_t row = 0; row < m->height; ++row)
            std::copy_n(m->data.begin() + std::ptrdiff_t(row * m->width), m->width,
                        grid_.data.begin() + std::ptrdiff_t((m->y + row) * width + std::size_t(m->x)));
        });
  }
  nav_msgs::OccupancyGrid grid() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return grid_;
  }
  std::size_t wholes() const { return locked(wholes_); }
  std::size_t parts() const { return locked(parts_); }
  std::size_t misfits() const { return locked(misfits_); }
  /// Wall seconds since the last whole map or part (infinite before the first).
  double quietSeconds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_.isZero() ? 1e9 : (ros::WallTime::now() - last_).toSec();
  }

 private:
  std::size_t locked(const std::size_t& value) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return value;
  }
  mutable std::mutex mutex_;
  nav_msgs::OccupancyGrid grid_;
  std::size_t wholes_ = 0, parts_ = 0, misfits_ = 0;
  ros::WallTime last_;
  ros::Subscriber whole_sub_, part_sub_;
};

}  // namespace llc_test
