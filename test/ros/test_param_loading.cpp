// Loading nodelet settings from the parameter-server representation, without a master.
#include <gtest/gtest.h>

#include <algorithm>

#include "ccir_mapping/ros/params.h"
#include "ccir_mapping/ros/yaml_params.h"

namespace ccir_mapping::ros_params {
namespace {

XmlRpc::XmlRpcValue params(const std::string& yaml) { return toXmlRpc(YAML::Load(yaml)); }

bool hasError(const ParamReader& reader, const std::string& start) {
  return std::any_of(reader.errors().begin(), reader.errors().end(),
                     [&](const std::string& e) { return e.rfind(start, 0) == 0; });
}

TEST(ParamLoading, AbsentNamespaceGivesValidDefaults) {
  ParamReader reader{XmlRpc::XmlRpcValue()};
  PreprocessorSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_EQ(settings.frames.odom_frame, "robot/odom");
  EXPECT_DOUBLE_EQ(settings.core.voxel_leaf_m, 0.1);
}

TEST(ParamLoading, ReadsValuesAndDerivesFramesFromTheRobotName) {
  ParamReader reader{params("{robot_name: uav2, voxel_leaf_m: 0.2, keyframe_distance_m: 2}")};
  PreprocessorSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_DOUBLE_EQ(settings.core.voxel_leaf_m, 0.2);
  EXPECT_DOUBLE_EQ(settings.core.keyframe_distance_m, 2.0);  // an int is accepted as a number
  EXPECT_EQ(settings.frames.map_frame, "uav2/map");
  EXPECT_EQ(settings.frames.base_frame, "uav2/base_link");
  EXPECT_NE(reader.summary().find("voxel_leaf_m=0.2"), std::string::npos);
}

TEST(ParamLoading, OutOfRangeValueNamesParameterAndRange) {
  ParamReader reader{params("{voxel_leaf_m: -1.0}")};
  PreprocessorSettings settings;
  load(reader, settings);
  ASSERT_EQ(reader.errors().size(), 1u);
  EXPECT_EQ(reader.errors()[0], "voxel_leaf_m = -1 is out of range: allowed [0.01, 5]");

  ParamReader queue_reader{params("{scan_queue_size: 0}")};
  PreprocessorSettings fresh;
  load(queue_reader, fresh);
  ASSERT_EQ(queue_reader.errors().size(), 1u);
  EXPECT_EQ(queue_reader.errors()[0], "scan_queue_size = 0 is out of range: allowed [1, 1000]");
}

TEST(ParamLoading, MatcherReadsScanContextSettingsIntoItsCoreStruct) {
  ParamReader reader{
      params("{method: scan_context, scan_context_max_range_m: 80, "
             "scan_context_ring_key_candidates: 25}")};
  MatcherSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_EQ(settings.core.method, core::place_recognition::MatchMethod::kScanContext);
  EXPECT_DOUBLE_EQ(settings.core.scan_context.max_range_m, 80.0);
  EXPECT_EQ(settings.core.scan_context.ring_key_candidates, 25);

  ParamReader bad{params("{scan_context_ring_key_candidates: 0}")};
  MatcherSettings fresh;
  load(bad, fresh);
  EXPECT_TRUE(hasError(bad, "scan_context_ring_key_candidates")) << bad.errors().size();
}

TEST(ParamLoading, MatcherReadsHgmmSettingsIntoItsCoreStruct) {
  ParamReader reader{
      params("{method: hgmm, hgmm_candidates: all, hgmm_max_depth: 2, hgmm_min_similarity: 0.3}")};
  MatcherSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_EQ(settings.core.method, core::place_recognition::MatchMethod::kHgmm);
  EXPECT_EQ(settings.core.hgmm.candidates, core::place_recognition::MixtureCandidates::kAll);
  EXPECT_EQ(settings.core.hgmm.model.max_depth, 2);
  EXPECT_DOUBLE_EQ(settings.core.hgmm.registration.min_similarity, 0.3);

  ParamReader bad{params("{hgmm_candidates: some, hgmm_max_depth: 11, hgmm_min_similarity: 2}")};
  MatcherSettings fresh;
  load(bad, fresh);
  for (const char* name : {"hgmm_candidates", "hgmm_max_depth", "hgmm_min_similarity"}) {
    EXPECT_TRUE(hasError(bad, name)) << name;
  }
}

TEST(ParamLoading, BrokerReadsItsScanEncoding) {
  ParamReader reader{params("{scan_encoding: gmm, gmm_max_bytes: 12000}")};
  BrokerSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_EQ(settings.core.scan_encoding, core::routing::ScanEncoding::kGmm);
  EXPECT_EQ(settings.core.gmm_max_bytes, 12000);

  ParamReader bad{params("{scan_encoding: points, gmm_max_bytes: 100}")};
  BrokerSettings fresh;
  load(bad, fresh);
  EXPECT_TRUE(hasError(bad, "scan_encoding"));
  EXPECT_TRUE(hasError(bad, "gmm_max_bytes"));
}

TEST(ParamLoading, WrongTypesAreErrors) {
  ParamReader reader{params("{voxel_leaf_m: fine, fixed_rate_every_n: 2.5, mode: 3}")};
  PreprocessorSettings pre;
  load(reader, pre);
  EXPECT_TRUE(hasError(reader, "voxel_leaf_m has the wrong type: expected a number"));

  ParamReader broker_reader{params("{fixed_rate_every_n: 2.5, mode: 3}")};
  BrokerSettings broker;
  load(broker_reader, broker);
  EXPECT_TRUE(
      hasError(broker_reader, "fixed_rate_every_n has the wrong type: expected an integer"));
  EXPECT_TRUE(hasError(broker_reader, "mode has the wrong type: expected a string"));
}

TEST(ParamLoading, UnknownChoiceListsTheAllowedOnes) {
  ParamReader reader{params("{robust_kernel: tukey}")};
  BackendSettings settings;
  load(reader, settings);
  ASSERT_EQ(reader.errors().size(), 1u);
  EXPECT_EQ(
      reader.errors()[0],
      "robust_kernel = 'tukey' is not allowed: allowed switchable | none | cauchy | huber | dcs");
}

TEST(ParamLoading, InvalidRobotNameAndFrames) {
  ParamReader reader{params("{robot_name: 'robot a', odom_frame: /odom}")};
  MapperSettings settings;
  load(reader, settings);
  EXPECT_TRUE(hasError(reader, "robot_name = 'robot a' is not a valid robot name"));
  EXPECT_TRUE(hasError(reader, "odom_frame = '/odom' is not allowed"));
}

TEST(ParamLoading, TheMapGraphAndTrajectoriesGoToRosHomeUnlessAFolderIsGiven) {
  ::setenv("ROS_HOME", "/tmp/some_ros_home", 1);
  MapperSettings mapper;
  ParamReader reader{params("{robot_name: robot_c}")};
  load(reader, mapper);
  EXPECT_EQ(mapper.save.dir, "/tmp/some_ros_home/ccir_mapping/robot_c");
  EXPECT_TRUE(mapper.save.on_shutdown);
  BackendSettings backend;
  ParamReader given{params("{robot_name: robot_c, save_dir: /data/c, save_on_shutdown: false}")};
  load(given, backend);
  EXPECT_TRUE(given.errors().empty());
  EXPECT_EQ(backend.save.dir, "/data/c");
  EXPECT_FALSE(backend.save.on_shutdown);
}

TEST(ParamLoading, ResumeIsReadWhereItActsAndRefusedWithLidarOdometry) {
  ::setenv("ROS_HOME", "/tmp/some_ros_home", 1);
  PreprocessorSettings preprocessor;
  ParamReader reader{params("{robot_name: robot_c, resume: true}")};
  load(reader, preprocessor);
  EXPECT_TRUE(reader.errors().empty());
  EXPECT_TRUE(preprocessor.save.resume);
  EXPECT_EQ(preprocessor.save.dir, "/tmp/some_ros_home/ccir_mapping/robot_c");
  // It writes no files: those keys are not its.
  ParamReader shutdown{params("{robot_name: robot_c, save_on_shutdown: false, save_period_s: 5}")};
  load(shutdown, preprocessor);
  EXPECT_EQ(shutdown.unknownKeys(),
            (std::vector<std::string>{"save_on_shutdown", "save_period_s"}));
  ParamReader lidar{params("{robot_name: robot_c, resume: true, odom_source: lidar}")};
  load(lidar, preprocessor);
  EXPECT_TRUE(hasError(lidar, "resume = true needs odometry that outlives the manager"));
  MapperSettings mapper;
  BackendSettings backend;
  ParamReader mapper_reader{params("{robot_name: robot_c, resume: true}")};
  ParamReader backend_reader{params("{robot_name: robot_c}")};
  load(mapper_reader, mapper);
  load(backend_reader, backend);
  EXPECT_TRUE(mapper.save.resume);
  EXPECT_FALSE(backend.save.resume) << "a new mission unless told";
  EXPECT_EQ(backend.save.period_s, 0.0) << "saved only on the services and at shutdown";
  ParamReader periodic{params("{robot_name: robot_c, save_period_s: 30.0}")};
  load(periodic, backend);
  EXPECT_EQ(backend.save.period_s, 30.0);
  ParamReader negative{params("{robot_name: robot_c, save_period_s: -1.0}")};
  load(negative, mapper);
  EXPECT_TRUE(hasError(negative, "save_period_s"));
}

TEST(ParamLoading, UnknownKeysAreReported) {
  ParamReader reader{params("{voxel_leaf: 0.2, voxel_leaf_m: 0.2}")};
  PreprocessorSettings settings;
  load(reader, settings);
  EXPECT_EQ(reader.unknownKeys(), std::vector<std::string>{"voxel_leaf"});
}

TEST(ParamLoading, BridgePeersAndTopics) {
  ParamReader reader{params(R"({robot_name: robot_a, team_key: 0123456789abcdef,
      peers: [{name: robot_b, host: 127.0.0.1, port: 17002},
              {name: robot_c, host: 10.0.0.3, port: 17003}],
      topics: [{topic: outbox/scans, priority: bulk, compress: true},
               {topic: outbox/offers, queue: keep_latest, max_age_s: 2, reliable: false}]})")};
  BridgeSettings settings;
  load(reader, settings);
  ASSERT_TRUE(reader.errors().empty()) << reader.errors()[0];
  ASSERT_EQ(settings.core.peers.size(), 2u);
  EXPECT_EQ(settings.core.peers[0].name, "robot_b");
  EXPECT_EQ(settings.core.peers[0].port, 17002);
  EXPECT_EQ(settings.core.peerNames(), (std::vector<std::string>{"robot_b", "robot_c"}));
  ASSERT_EQ(settings.core.topics.size(), 2u);
  EXPECT_EQ(settings.core.topics[0].policy.priority, core::transport::Priority::kBulk);
  EXPECT_TRUE(settings.core.topics[0].compress);
  EXPECT_TRUE(settings.core.topics[0].reliable);
  EXPECT_EQ(settings.core.topics[1].policy.priority, core::transport::Priority::kControl);
  EXPECT_EQ(settings.core.topics[1].policy.queue, core::transport::QueuePolicy::kKeepLatest);
  EXPECT_EQ(settings.core.topics[1].policy.max_age_s, 2.0);
  EXPECT_FALSE(settings.core.topics[1].reliable);
}

TEST(ParamLoading, BridgeDefaultsForwardTheWholeProtocol) {
  ParamReader reader{params("{robot_name: robot_a}")};
  BridgeSettings settings;
  load(reader, settings);
  EXPECT_TRUE(reader.errors().empty());
  ASSERT_EQ(settings.core.topics.size(), 6u);
  EXPECT_EQ(settings.core.topics[4].topic, "outbox/loop_closures");
  EXPECT_EQ(settings.core.topics[4].policy.priority, core::transport::Priority::kControl);
  EXPECT_EQ(settings.core.topics[5].topic, "outbox/scans");
  EXPECT_EQ(settings.core.topics[5].policy.priority, core::transport::Priority::kBulk);
}

TEST(ParamLoading, MalformedBridgeLists) {
  ParamReader reader{
      params("{peers: {name: robot_b}, topics: [outbox/scans, {topic: outbox/x, priority: urgent},"
             " {topic: outbox/y, prority: bulk, max_queued: many}]}")};
  BridgeSettings settings;
  load(reader, settings);
  EXPECT_TRUE(hasError(reader, "peers has the wrong type: expected a list"));
  EXPECT_TRUE(hasError(reader, "topics[0] has the wrong type: expected a dictionary"));
  EXPECT_TRUE(hasError(reader, "topics[1].priority = 'urgent' is not allowed"));
  EXPECT_TRUE(hasError(reader, "topics[2].prority is not a known field"));
  EXPECT_TRUE(hasError(reader, "topics[2].max_queued has the wrong type"));
}

TEST(ParamLoading, ABridgeWithPeersNeedsATeamKey) {
  ParamReader reader{params(R"({robot_name: robot_a, listen_port: 17001,
      peers: [{name: robot_b, host: 127.0.0.1, port: 17002}]})")};
  BridgeSettings settings;
  load(reader, settings);
  EXPECT_TRUE(hasError(reader, "team_key must be at least 16 characters"));
}

TEST(ParamLoading, ANonStructNamespaceIsAnError) {
  ParamReader reader{XmlRpc::XmlRpcValue(3)};
  EXPECT_FALSE(reader.errors().empty());
}

}  // namespace
}  // namespace ccir_mapping::ros_params
