// Standalone node running the ScanSplitter nodelet (one code path for both).
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "scan_splitter");
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "tilt_laser_perception/ScanSplitter", remappings, my_argv)) {
    ROS_FATAL("could not load the tilt_laser_perception/ScanSplitter nodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
