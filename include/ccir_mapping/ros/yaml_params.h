// A YAML document as the XmlRpc value rosparam would put on the parameter server, so that what
// runs without a master (run_team, tests) reads a robot's configuration file with the nodelets'
// own loaders (ParamReader, ros_params::load).
#pragma once

#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

namespace ccir_mapping::ros_params {

/// Maps become structs, sequences arrays; a plain scalar becomes a bool, int or double when it
/// reads as one (as rosparam does), a quoted one always a string.
XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node);

}  // namespace ccir_mapping::ros_params
