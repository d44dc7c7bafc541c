// Test helper: spins ROS callbacks until a condition holds or a timeout passes.
#pragma once

#include <functional>
#include <string>

#include <ros/master.h>
#include <ros/ros.h>

namespace ccir_mapping::testing {

/// Returns true as soon as `condition` holds; false after `timeout_s` of wall time.
inline bool waitFor(const std::function<bool()>& condition, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (condition()) return true;
    ros::WallDuration(0.005).sleep();  // polling interval, not synchronisation
  }
  ros::spinOnce();
  return condition();
}

/// The number of nodes the master lists as publishing `topic` (resolved), or -1 if it cannot say.
inline int registeredPublishers(const std::string& topic) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", args, result, payload, true)) return -1;
  XmlRpc::XmlRpcValue& publishers = payload[0];
  for (int i = 0; i < publishers.size(); ++i) {
    if (static_cast<std::string>(publishers[i][0]) == topic) return publishers[i][1].size();
  }
  return 0;
}

/// Whether `subscriber` is linked to every publisher the master knows of. For a topic that is
/// not latched (/rosout) this must hold before provoking a message the test means to hear.
inline bool linkedToAllPublishers(const ros::Subscriber& subscriber) {
  const int registered = registeredPublishers(subscriber.getTopic());
  return registered > 0 && static_cast<int>(subscriber.getNumPublishers()) >= registered;
}

}  // namespace ccir_mapping::testing
