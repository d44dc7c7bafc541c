// Every YAML shipped in config/ loads into the nodelets' settings without an error or an
// unknown key, so a broken default never reaches a robot.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/yaml_params.h"

namespace ccir_mapping::ros_params {
namespace {

template <class Settings>
void expectValid(const std::string& file, const std::string& section, const YAML::Node& node) {
  XmlRpc::XmlRpcValue values = toXmlRpc(node);
  // robot_name comes from the launch file.
  if (values.getType() == XmlRpc::XmlRpcValue::TypeStruct) values["robot_name"] = "robot_a";
  ParamReader reader(values, file + ":" + section);
  Settings settings;
  load(reader, settings);
  for (const auto& error : reader.errors())
    ADD_FAILURE() << file << ":" << section << ": " << error;
  for (const auto& key : reader.unknownKeys()) {
    ADD_FAILURE() << file << ":" << section << ": unknown key " << key;
  }
}

std::vector<std::filesystem::path> configFiles() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(CCIR_CONFIG_DIR)) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path());
  }
  return files;
}

TEST(ConfigFiles, EveryShippedYamlLoadsAndValidates) {
  const auto files = configFiles();
  ASSERT_FALSE(files.empty()) << "no YAML under " << CCIR_CONFIG_DIR;
  for (const auto& path : files) {
    SCOPED_TRACE(path.string());
    const YAML::Node root = YAML::LoadFile(path.string());
    ASSERT_TRUE(root.IsMap()) << path;
    for (const auto& item : root) {
      const std::string section = item.first.as<std::string>();
      const std::string file = path.filename().string();
      if (section == "preprocessor")
        expectValid<PreprocessorSettings>(file, section, item.second);
      else if (section == "matcher")
        expectValid<MatcherSettings>(file, section, item.second);
      else if (section == "backend")
        expectValid<BackendSettings>(file, section, item.second);
      else if (section == "mapper")
        expectValid<MapperSettings>(file, section, item.second);
      else if (section == "broker")
        expectValid<BrokerSettings>(file, section, item.second);
      else if (section == "bridge")
        expectValid<BridgeSettings>(file, section, item.second);
      else
        ADD_FAILURE() << file << ": unknown section " << section;
    }
  }
}

TEST(ConfigFiles, TheDefaultConfigCoversEveryNodelet) {
  const YAML::Node root = YAML::LoadFile(std::string(CCIR_CONFIG_DIR) + "/robot.yaml");
  for (const char* section : {"preprocessor", "matcher", "backend", "mapper", "broker", "bridge"}) {
    EXPECT_TRUE(root[section].IsMap()) << section;
  }
}

}  // namespace
}  // namespace ccir_mapping::ros_params
