// The run-time keys of each reconfigurable nodelet (cfg/*.cfg), read by the nodelets and by
// test_reconfigure_bounds.
#pragma once

#include "ccir_mapping/BrokerConfig.h"
#include "ccir_mapping/PreprocessorConfig.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/ros/reconfigure_table.h"

namespace ccir_mapping::ros_params {

using PreprocessorReconfigure =
    ReconfigureTable<PreprocessorConfig, core::preprocess::PreprocessorParams>;
using BrokerReconfigure = ReconfigureTable<BrokerConfig, core::routing::BrokerParams>;

inline const PreprocessorReconfigure& preprocessorReconfigure() {
  using C = PreprocessorConfig;
  using P = core::preprocess::PreprocessorParams;
  static const PreprocessorReconfigure table =
      PreprocessorReconfigure()
          .add("min_range_m", &C::min_range_m, &P::min_range_m)
          .add("max_range_m", &C::max_range_m, &P::max_range_m)
          .add("voxel_leaf_m", &C::voxel_leaf_m, &P::voxel_leaf_m)
          .add("normal_radius_m", &C::normal_radius_m, &P::normal_radius_m)
          .add("horizontal_normal_z", &C::horizontal_normal_z, &P::horizontal_normal_z)
          .add("keyframe_distance_m", &C::keyframe_distance_m, &P::keyframe_distance_m)
          .add("keyframe_rotation_deg", &C::keyframe_rotation_deg, &P::keyframe_rotation_deg);
  return table;
}

inline const BrokerReconfigure& brokerReconfigure() {
  using C = BrokerConfig;
  using P = core::routing::BrokerParams;
  static const BrokerReconfigure table =
      BrokerReconfigure()
          .add("loop_closure_weight", &C::loop_closure_weight, &P::loop_closure_weight)
          .add("unknown_transform_factor", &C::unknown_transform_factor,
               &P::unknown_transform_factor)
          .add("fixed_rate_every_n", &C::fixed_rate_every_n, &P::fixed_rate_every_n);
  return table;
}

}  // namespace ccir_mapping::ros_params
