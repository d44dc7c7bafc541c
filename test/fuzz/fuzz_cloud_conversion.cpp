// libFuzzer target: a PointCloud2 as a driver, a bag or a misconfigured node may publish it,
// through the conversions the nodelets apply before anything else (conversions::checkCloud and
// toPcl in the Preprocessor, toKeyframeCloud in the Matcher, toScanPoints in the Mapper). The
// layout (fields by name, type, count and offset, steps, sizes) is drawn from the input, the
// data are the rest: a conversion either refuses with a reason or reads only inside the data.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "ccir_mapping/ros/conversions.h"

namespace conversions = ccir_mapping::conversions;

namespace {

const char* const kFieldNames[] = {"x", "y",        "z",        "intensity", "ring",      "time",
                                   "t", "normal_x", "normal_y", "normal_z",  "curvature", "rgb"};

sensor_msgs::PointCloud2 cloudFrom(FuzzedDataProvider& input) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = "velodyne";
  const int fields = input.ConsumeIntegralInRange<int>(0, 14);
  for (int i = 0; i < fields; ++i) {
    sensor_msgs::PointField field;
    field.name = input.PickValueInArray(kFieldNames);
    field.datatype = input.ConsumeIntegralInRange<std::uint8_t>(0, 9);
    field.count = input.ConsumeBool() ? 1 : input.ConsumeIntegral<std::uint32_t>();
    // Mostly small offsets (a real layout), sometimes anything (an overflow).
    field.offset = input.ConsumeBool() ? input.ConsumeIntegralInRange<std::uint32_t>(0, 64)
                                       : input.ConsumeIntegral<std::uint32_t>();
    cloud.fields.push_back(field);
  }
  cloud.is_bigendian = input.ConsumeIntegralInRange<int>(0, 7) == 0;
  cloud.is_dense = input.ConsumeBool();
  cloud.height = input.ConsumeIntegralInRange<std::uint32_t>(0, 4);
  cloud.width = input.ConsumeIntegralInRange<std::uint32_t>(0, 64);
  cloud.point_step = input.ConsumeBool() ? input.ConsumeIntegralInRange<std::uint32_t>(0, 64)
                                         : input.ConsumeIntegral<std::uint32_t>();
  const bool consistent_row_step = input.ConsumeBool();
  cloud.row_step =
      consistent_row_step ? cloud.width * cloud.point_step : input.ConsumeIntegral<std::uint32_t>();
  // The data: the rest of the input, or as much as the steps say when there is enough of it.
  cloud.data = input.ConsumeRemainingBytes<std::uint8_t>();
  const std::uint64_t expected = std::uint64_t{cloud.row_step} * cloud.height;
  if (consistent_row_step && expected <= (1u << 20) && cloud.data.size() < expected) {
    cloud.data.resize(expected);
  }
  return cloud;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  ccir_mapping::Keyframe keyframe;
  keyframe.odom_pose.orientation.w = 1.0;
  keyframe.cloud = cloudFrom(input);

  conversions::CloudFields fields;
  if (const auto error = conversions::checkCloud(keyframe.cloud, &fields)) {
    if (error->empty()) std::abort();  // a refusal names its reason
  } else {
    conversions::missingVelodyneFields(fields);
    pcl::PointCloud<pcl::PointXYZI> scan;
    conversions::toPcl(keyframe.cloud, &scan);
    if (scan.size() != std::size_t{keyframe.cloud.width} * keyframe.cloud.height) std::abort();
  }
  pcl::PointCloud<pcl::PointXYZINormal> full;
  if (const auto error = conversions::toKeyframeCloud(keyframe.cloud, &full)) {
    if (error->empty()) std::abort();
  }
  pcl::PointCloud<pcl::PointXYZ> points;
  ccir_mapping::core::Pose3 pose;
  if (const auto error = conversions::toScanPoints(keyframe, &points, &pose)) {
    if (error->empty()) std::abort();
  }
  return 0;
}
