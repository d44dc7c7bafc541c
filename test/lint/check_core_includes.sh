#!/usr/bin/env bash
# Fails when a file under the ROS-free core includes a ROS header. Prints each offending line.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
pattern='^\s*#\s*include\s*[<"](ros|sensor_msgs|nodelet|pcl_ros|pcl_conversions|tf2_ros|tf2_eigen|tf2_geometry_msgs|geometry_msgs|nav_msgs|std_msgs|visualization_msgs|diagnostic_msgs|diagnostic_updater|dynamic_reconfigure|rosbag|topic_tools|xmlrpcpp|pluginlib|message_filters|mrpt/ros1bridge|ccir_mapping/ros|ccir_mapping/[A-Z])[/_A-Za-z]'
dirs=("$root/include/ccir_mapping/core" "$root/src/core")
if hits=$(grep -rnE "$pattern" "${dirs[@]}" 2>/dev/null); then
  echo "ROS headers included in the ROS-free core:"
  echo "$hits"
  exit 1
fi
echo "core include check: $(find "${dirs[@]}" -type f | wc -l) files, no ROS header"
