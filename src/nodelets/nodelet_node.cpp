// A node executable that loads one of this package's nodelets in its own process, for users
// who do not want a nodelet manager: llc_esdf_backend_node, llc_loop_closure_node and
// llc_scan_merger_node are this file built with LLC_NODELET set.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, LLC_NODE_NAME);
  nodelet::Loader loader(false);  // no load/unload services: this process runs one nodelet
  nodelet::M_string remappings(ros::names::getRemappings());
  nodelet::V_string arguments(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), LLC_NODELET, remappings, arguments)) {
    ROS_FATAL("%s: could not load nodelet %s", ros::this_node::getName().c_str(), LLC_NODELET);
    return 1;
  }
  ros::spin();
  return 0;
}
