// The multi_robot_backend nodelet: builds its adapter object (src/ros/nodes/multi_robot_backend_ros.cpp) and nothing else.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

#include "laser_loop_closure/ros/nodes/multi_robot_backend_ros.hpp"

namespace laser_loop_closure {

class MultiRobotBackendNodelet : public nodelet::Nodelet {
  void onInit() override {
    try {
      ros_ = std::make_unique<llc_ros::MultiRobotBackendRos>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s", e.what());
      throw;  // the manager reports the nodelet as not loaded
    }
  }
  std::unique_ptr<llc_ros::MultiRobotBackendRos> ros_;
};

}  // namespace laser_loop_closure

PLUGINLIB_EXPORT_CLASS(laser_loop_closure::MultiRobotBackendNodelet, nodelet::Nodelet)
