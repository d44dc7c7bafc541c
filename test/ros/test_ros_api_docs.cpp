// docs/ros_api.md's parameter tables against the code and config/robot.yaml: every parameter a
// nodelet reads is documented with the default it has, and every documented one is read; every
// key of robot.yaml's section is documented, with the value robot.yaml gives it as default.
#include <gtest/gtest.h>

#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "ccir_mapping/ros/params.h"

namespace ccir_mapping::ros_params {
namespace {

/// Name -> default, as a parameter table's rows give them, by section ("Every nodelet",
/// "ccir_mapping/Preprocessor", ...).
using Table = std::map<std::string, std::string>;

std::map<std::string, Table> documentedParameters() {
  const std::string path = std::string(CCIR_DOCS_DIR) + "/ros_api.md";
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::map<std::string, Table> tables;
  const std::regex section(R"(^## (.+)$)");
  const std::regex row(R"(^\| `([a-z0-9_]+)` \| ([^|]*) \|)");
  std::string line, current;
  bool in_parameters = false;
  for (std::smatch m; std::getline(in, line);) {
    if (std::regex_match(line, m, section)) {
      current = m[1];
      in_parameters = false;
    } else if (line.rfind("### ", 0) == 0) {
      in_parameters = line == "### Parameters";
    } else if (in_parameters && std::regex_search(line, m, row)) {
      tables[current][m[1]] = m[2];
    }
  }
  return tables;
}

/// A default as the docs, the reader (its effective value) or YAML write it, made comparable:
/// no backticks or quotes, `<robot_name>` filled in (the reader's default), numbers as numbers.
std::string normalised(std::string text) {
  for (const char* quote : {"`", "'", "\""}) {
    for (std::size_t at; (at = text.find(quote)) != std::string::npos;) text.erase(at, 1);
  }
  text = std::regex_replace(text, std::regex("^ +| +$"), "");
  text = std::regex_replace(text, std::regex("<robot_name>"), "robot");
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  if (!text.empty() && end && *end == '\0') {
    std::ostringstream out;
    out.precision(12);
    out << number;
    return out.str();
  }
  return text;
}

template <class Settings>
void expectDocumented(const std::string& nodelet, const std::string& section) {
  SCOPED_TRACE(nodelet);
  const auto tables = documentedParameters();
  ASSERT_TRUE(tables.count("ccir_mapping/" + nodelet)) << "no parameter table for " << nodelet;
  Table documented = tables.at("ccir_mapping/" + nodelet);
  if (tables.count("Every nodelet")) {
    for (const auto& [name, value] : tables.at("Every nodelet")) documented[name] = value;
  }
  // What the nodelet reads, with its defaults: no parameter set.
  ParamReader reader(XmlRpc::XmlRpcValue{}, section);
  Settings settings;
  load(reader, settings);
  for (const auto& key : reader.knownKeys()) {
    EXPECT_TRUE(documented.count(key)) << key << " is read but not in docs/ros_api.md";
  }
  for (const auto& [name, value] : documented) {
    EXPECT_TRUE(reader.knownKeys().count(name)) << name << " is documented but not read";
  }
  for (const auto& [key, value] : reader.effective()) {
    if (documented.count(key)) {
      EXPECT_EQ(normalised(documented.at(key)), normalised(value)) << key << "'s default";
    }
  }
  // robot.yaml's section: documented, each with the default it states.
  const YAML::Node yaml = YAML::LoadFile(std::string(CCIR_CONFIG_DIR) + "/robot.yaml")[section];
  ASSERT_TRUE(yaml.IsMap()) << section;
  for (const auto& item : yaml) {
    const std::string key = item.first.as<std::string>();
    ASSERT_TRUE(documented.count(key)) << "robot.yaml's " << key << " is not documented";
    if (item.second.IsScalar()) {
      EXPECT_EQ(normalised(documented.at(key)), normalised(item.second.Scalar()))
          << "robot.yaml's " << key;
    }
  }
}

TEST(RosApiDocs, PreprocessorParameters) {
  expectDocumented<PreprocessorSettings>("Preprocessor", "preprocessor");
}
TEST(RosApiDocs, MatcherParameters) { expectDocumented<MatcherSettings>("Matcher", "matcher"); }
TEST(RosApiDocs, BackendParameters) { expectDocumented<BackendSettings>("Backend", "backend"); }
TEST(RosApiDocs, MapperParameters) { expectDocumented<MapperSettings>("Mapper", "mapper"); }
TEST(RosApiDocs, BrokerParameters) { expectDocumented<BrokerSettings>("Broker", "broker"); }
TEST(RosApiDocs, BridgeParameters) { expectDocumented<BridgeSettings>("Bridge", "bridge"); }

TEST(RosApiDocs, NormalisedDefaultsCompareAsTheyRead) {
  EXPECT_EQ(normalised("`150000.0`"), normalised("150000"));
  EXPECT_EQ(normalised("2e+06"), normalised("2000000"));
  EXPECT_EQ(normalised("`'topic'`"), "topic");
  EXPECT_EQ(normalised("`<robot_name>/map`"), "robot/map");
  EXPECT_NE(normalised("0.5"), normalised("0.25"));
}

}  // namespace
}  // namespace ccir_mapping::ros_params
