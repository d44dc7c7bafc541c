#include "ccir_mapping/ros/yaml_params.h"

#include <exception>
#include <string>

namespace ccir_mapping::ros_params {

XmlRpc::XmlRpcValue toXmlRpc(const YAML::Node& node) {
  XmlRpc::XmlRpcValue out;
  switch (node.Type()) {
    case YAML::NodeType::Map:
      out.begin();  // makes it an (empty) struct
      for (const auto& item : node) out[item.first.as<std::string>()] = toXmlRpc(item.second);
      return out;
    case YAML::NodeType::Sequence:
      out.setSize(static_cast<int>(node.size()));
      for (std::size_t i = 0; i < node.size(); ++i) out[static_cast<int>(i)] = toXmlRpc(node[i]);
      return out;
    case YAML::NodeType::Scalar: {
      const std::string text = node.Scalar();
      if (node.Tag() == "!") return XmlRpc::XmlRpcValue(text);  // quoted: always a string
      if (text == "true" || text == "false") return XmlRpc::XmlRpcValue(text == "true");
      try {
        std::size_t used = 0;
        const long value = std::stol(text, &used);
        if (used == text.size()) return XmlRpc::XmlRpcValue(static_cast<int>(value));
      } catch (const std::exception&) {
      }
      try {
        std::size_t used = 0;
        const double value = std::stod(text, &used);
        if (used == text.size()) return XmlRpc::XmlRpcValue(value);
      } catch (const std::exception&) {
      }
      return XmlRpc::XmlRpcValue(text);
    }
    default:
      return out;
  }
}

}  // namespace ccir_mapping::ros_params
