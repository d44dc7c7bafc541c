// Test helper: spins ROS callbacks until a condition holds or a timeout passes.
#pragma once

#include <functional>

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

}  // namespace ccir_mapping::testing
