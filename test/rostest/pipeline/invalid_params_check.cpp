// A nodelet with an invalid parameter (or a Matcher whose model directory does not exist, a
// Broker without the Bridge or the Mapper it names) logs FATAL naming it, reports ERROR on
// diagnostics and stays inert; the valid nodelets in the same manager keep running.
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <utility>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nodelet/NodeletLoad.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>

#include "wait_for.h"

namespace {

using ccir_mapping::testing::waitFor;

bool advertised(const std::string& topic) {
  ros::master::V_TopicInfo topics;
  ros::master::getTopics(topics);
  for (const auto& info : topics) {
    if (info.name == topic) return true;
  }
  return false;
}

TEST(InvalidParams, FatalNamesTheParameterAndTheNodeletStaysInert) {
  ros::NodeHandle nh;
  std::vector<rosgraph_msgs::Log::ConstPtr> log;  // everything on /rosout since subscribing
  std::map<std::string, diagnostic_msgs::DiagnosticStatus> status;
  auto log_sub = nh.subscribe<rosgraph_msgs::Log>(
      "/rosout", 1000, [&](const rosgraph_msgs::Log::ConstPtr& m) { log.push_back(m); });
  auto diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const auto& s : m->status) status[s.name] = s;
      });
  auto logged = [&](std::uint8_t level, const std::string& text) {
    for (const auto& m : log) {
      if (m->level == level && m->msg.find(text) != std::string::npos) return true;
    }
    return false;
  };
  auto fatal = [&](const std::string& text) { return logged(rosgraph_msgs::Log::FATAL, text); };

  // /rosout is not latched: load the nodelets only once this test hears the manager's log.
  ASSERT_TRUE(ros::service::waitForService("/manager/load_nodelet", ros::Duration(30.0)));
  ASSERT_TRUE(waitFor([&] { return ccir_mapping::testing::linkedToAllPublishers(log_sub); }, 30.0))
      << "not linked to every /rosout publisher (" << log_sub.getNumPublishers() << " of "
      << ccir_mapping::testing::registeredPublishers("/rosout") << ")";
  const std::pair<const char*, const char*> nodelets[] = {{"preprocessor", "Preprocessor"},
                                                          {"bridge", "Bridge"},
                                                          {"matcher", "Matcher"},
                                                          {"matcher_without_model", "Matcher"},
                                                          {"backend_resuming", "Backend"},
                                                          {"backend", "Backend"},
                                                          {"broker_without_bridge", "Broker"},
                                                          {"broker", "Broker"}};
  for (const auto& [name, type] : nodelets) {
    nodelet::NodeletLoad load;
    load.request.name = std::string("/") + name;
    load.request.type = std::string("ccir_mapping/") + type;
    ASSERT_TRUE(ros::service::call("/manager/load_nodelet", load)) << name;
    EXPECT_TRUE(load.response.success) << name;
  }

  EXPECT_TRUE(
      waitFor([&] { return fatal("voxel_leaf_m = -1 is out of range: allowed [0.01, 5]"); }, 30.0));
  EXPECT_TRUE(waitFor(
      [&] { return fatal("peers[0].port = 99999 is out of range: allowed [1, 65535]"); }, 30.0));
  EXPECT_TRUE(waitFor(
      [&] {
        return fatal(
            "model_dir: cannot load the place-recognition model: /nonexistent/model is "
            "not a directory");
      },
      30.0));
  // Resuming from a save_dir that cannot be created is fatal; without resume the Backend runs,
  // its graph not journaled.
  EXPECT_TRUE(waitFor(
      [&] {
        return fatal("cannot create /proc/ccir_mapping_cannot_write") &&
               fatal("(save_dir, resume)");
      },
      30.0));
  EXPECT_TRUE(waitFor(
      [&] { return logged(rosgraph_msgs::Log::ERROR, "(save_dir): not journaled"); }, 30.0));
  // The Broker's explicit inputs: a Bridge that does not exist stops it at once; a Mapper that
  // never loads, once it has had 20 s to.
  EXPECT_TRUE(waitFor(
      [&] { return fatal("bridge: no nodelet named /nowhere (it has no parameters)"); }, 30.0));
  EXPECT_TRUE(
      waitFor([&] { return fatal("mapper: no Mapper named /mapper runs in this manager"); }, 75.0));
  // Diagnostics say why the nodelets are inert (published a second after onInit returned).
  ASSERT_TRUE(waitFor(
      [&] {
        return status.count("preprocessor: flow") && status.count("bridge: flow") &&
               status.count("matcher: flow") && status.count("matcher_without_model: flow") &&
               status.count("backend_resuming: flow") && status.count("backend: flow") &&
               status.count("broker_without_bridge: flow") && status.count("broker: flow");
      },
      30.0))
      << [&] {
           std::string names;
           for (const auto& [name, s] : status) names += " '" + name + "'";
           return "diagnostics seen:" + names;
         }();
  EXPECT_EQ(status["preprocessor: flow"].level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(status["bridge: flow"].level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(status["matcher: flow"].level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(status["matcher_without_model: flow"].level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(status["backend_resuming: flow"].level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(status["backend: flow"].level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(status["broker_without_bridge: flow"].level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_TRUE(waitFor(
      [&] { return status["broker: flow"].level == diagnostic_msgs::DiagnosticStatus::ERROR; },
      10.0))
      << "the Broker without its Mapper stops";
  ASSERT_FALSE(status["preprocessor: flow"].values.empty());
  EXPECT_EQ(status["preprocessor: flow"].values[0].value,
            "voxel_leaf_m = -1 is out of range: allowed [0.01, 5]");
  // Inert: nothing advertised by the invalid nodelets, the valid Matcher advertises features.
  EXPECT_FALSE(advertised("/keyframes"));
  EXPECT_FALSE(advertised("/link_stats"));
  EXPECT_TRUE(advertised("/features"));
  EXPECT_TRUE(advertised("/trajectory")) << "the Backend without resume runs unjournaled";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "invalid_params_check");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
