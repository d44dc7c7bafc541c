// Lidar odometry for robots and bags without wheel odometry: each scan is aligned with GICP
// (PCL) to a local map of the last registered scans, starting from a constant-velocity
// prediction. The odometry frame is the sensor frame of the first scan. Written here because
// PCL has the registration but no odometry around it.
#pragma once

#include <deque>
#include <memory>
#include <optional>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ccir_mapping/core/common/notice.h"
#include "ccir_mapping/core/common/types.h"
#include "ccir_mapping/core/preprocess/lidar_odometry_params.h"

namespace ccir_mapping::core::preprocess {

class LidarOdometry {
 public:
  using Cloud = pcl::PointCloud<pcl::PointXYZI>;

  struct Result {
    /// The sensor at the scan's stamp in the odometry frame.
    Pose3 pose = Pose3::Identity();
    /// False when the scan was placed by the motion prediction alone (too few points, GICP
    /// did not converge or fitted badly); `notice` says why.
    bool registered = false;
    double fitness_m2 = 0.0;
    std::optional<Notice> notice;
  };

  /// Throws std::invalid_argument when params.validate() reports errors.
  explicit LidarOdometry(const LidarOdometryParams& params);
  ~LidarOdometry();

  /// Places a scan (points in the sensor frame, non-finite ones ignored) taken at `stamp`.
  /// Scans come in stamp order; one not after the previous one gets the previous pose.
  Result track(Stamp stamp, const Cloud& scan);

  /// Points in the local map (for diagnostics and tests).
  std::size_t localMapPoints() const;

 private:
  class Registration;
  Pose3 predict(Stamp stamp) const;
  void addToLocalMap(const pcl::PointCloud<pcl::PointXYZ>& scan, const Pose3& pose);

  LidarOdometryParams params_;
  std::unique_ptr<Registration> registration_;
  std::deque<pcl::PointCloud<pcl::PointXYZ>::Ptr> local_scans_;  // in the odometry frame
  std::optional<Pose3> last_local_map_pose_;
  struct Placed {
    Stamp stamp;
    Pose3 pose;
  };
  std::optional<Placed> last_, before_last_;
};

}  // namespace ccir_mapping::core::preprocess
