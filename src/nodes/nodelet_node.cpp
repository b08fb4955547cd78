// Standalone node running one nodelet of the package (one code path for both):
// built once per nodelet with TLP_NODELET_TYPE and TLP_NODE_NAME.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, TLP_NODE_NAME);
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), TLP_NODELET_TYPE, remappings, my_argv)) {
    ROS_FATAL("could not load the %s nodelet", TLP_NODELET_TYPE);
    return 1;
  }
  ros::spin();
  return 0;
}
