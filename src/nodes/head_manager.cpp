// tilt_laser_head: a nodelet manager that loads the head's nodelets itself,
// from its ~nodelets parameter (a list of {name, type[, enabled: bool][, remap:
// {from: to}]}, names and remappings relative to the manager's namespace),
// so that the head runs as one process: no loader process per nodelet (each
// `nodelet load` client is a process of its own, 15 MB resident). It keeps
// the manager's ROS interface, so other nodelets can still be loaded into it,
// and on a respawn it loads its own again. The nodelets' parameters live in
// their namespaces as for any nodelet (launch/hrp4.launch sets them).
#include <string>

#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "tilt_laser_manager");
  nodelet::Loader manager(true);
  ros::NodeHandle pnh("~");
  XmlRpc::XmlRpcValue list;
  if (pnh.getParam("nodelets", list) && list.getType() == XmlRpc::XmlRpcValue::TypeArray) {
    const nodelet::V_string no_args;
    for (int i = 0; i < list.size(); ++i) {
      XmlRpc::XmlRpcValue& n = list[i];
      if (n.getType() != XmlRpc::XmlRpcValue::TypeStruct || !n.hasMember("name") || !n.hasMember("type")) {
        ROS_ERROR("~nodelets[%d]: needs a name and a type", i);
        continue;
      }
      if (n.hasMember("enabled") && n["enabled"].getType() == XmlRpc::XmlRpcValue::TypeBoolean && !static_cast<bool>(n["enabled"]))
        continue;
      const std::string name = ros::names::resolve(static_cast<std::string>(n["name"]));
      const std::string type = static_cast<std::string>(n["type"]);
      nodelet::M_string remap;
      if (n.hasMember("remap") && n["remap"].getType() == XmlRpc::XmlRpcValue::TypeStruct)
        for (auto it = n["remap"].begin(); it != n["remap"].end(); ++it)
          remap[ros::names::resolve(it->first)] = ros::names::resolve(static_cast<std::string>(it->second));
      if (!manager.load(name, type, remap, no_args)) ROS_ERROR("could not load the %s nodelet %s", type.c_str(), name.c_str());
      else ROS_INFO("loaded %s (%s)", name.c_str(), type.c_str());
    }
  }
  ros::spin();
  return 0;
}
