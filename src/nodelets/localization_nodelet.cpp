// The localization nodelet: builds its adapter object (src/ros/nodes/localization_ros.cpp) and nothing else.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

#include "laser_loop_closure/ros/nodes/localization_ros.hpp"

namespace laser_loop_closure {

class LocalizationNodelet : public nodelet::Nodelet {
  void onInit() override {
    try {
      ros_ = std::make_unique<llc_ros::LocalizationRos>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s", e.what());
      throw;  // the manager reports the nodelet as not loaded
    }
  }
  std::unique_ptr<llc_ros::LocalizationRos> ros_;
};

}  // namespace laser_loop_closure

PLUGINLIB_EXPORT_CLASS(laser_loop_closure::LocalizationNodelet, nodelet::Nodelet)
