// Command-line flags of the feature settings (core::features::FeatureParams) that the tools which
// describe keyframes share: train_place_model records them in the model, eval_features studies
// them.
#pragma once

#include <string>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/features/feature_params.h"

namespace ccir_mapping::tools {

class FeatureOptions {
 public:
  /// Adds --feature-* flags defaulting to `params` (whose fields they write).
  FeatureOptions(boost::program_options::options_description* options,
                 core::features::FeatureParams* params)
      : params_(params), drop_horizontal_(core::preprocess::toString(params->drop_horizontal)) {
    namespace po = boost::program_options;
    auto number = [&](const char* flag, double* field, const char* help) {
      options->add_options()(flag, po::value<double>(field)->default_value(*field), help);
    };
    options->add_options()(
        "feature-drop-horizontal",
        po::value<std::string>(&drop_horizontal_)->default_value(drop_horizontal_),
        "degenerate-normal filter of the features: none | ground | ceiling | both");
    number("feature-voxel-m", &params->voxel_m, "voxel edge the features are computed on [m]");
    number("feature-normal-radius-m", &params->normal_radius_m, "normal estimation radius [m]");
    number("iss-salient-radius-m", &params->iss_salient_radius_m, "ISS salient radius [m]");
    number("iss-non-max-radius-m", &params->iss_non_max_radius_m,
           "ISS non-maximum suppression radius [m]");
    number("spin-support-m", &params->spin_support_m, "spin-image support radius [m]");
  }

  /// After parsing: the filter's name resolved and every field checked; the first error or "".
  std::string apply() const {
    const auto filter = core::preprocess::parseHorizontalFilter(drop_horizontal_);
    if (!filter) return "--feature-drop-horizontal: not one of none | ground | ceiling | both";
    params_->drop_horizontal = *filter;
    const auto errors = params_->validate();
    return errors.empty() ? "" : errors.front();
  }

 private:
  core::features::FeatureParams* params_;
  std::string drop_horizontal_;
};

}  // namespace ccir_mapping::tools
