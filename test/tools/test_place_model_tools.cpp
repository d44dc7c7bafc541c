// train_place_model and eval_features on a simulated mission fixture (two robots that meet): the
// new-place samples come from other keyframes than the tree's, the model records its feature
// settings, and the feature study reports counts and repeatability. No master needed.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>

#include <yaml-cpp/yaml.h>

#include "ccir_mapping/core/place_recognition/place_model.h"
#include "command_run.h"

namespace ccir_mapping {
namespace {

namespace fs = std::filesystem;

const fs::path kMission(MISSION_DIR);

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("ccir_model_tools_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

test::CommandRun train(const std::string& arguments) {
  return test::runCommand(std::string(TRAIN_PLACE_MODEL) + " --words 50 " + arguments);
}

/// The keyframe count train_place_model printed for `bag`.
int keyframesOf(const std::string& output, const std::string& bag) {
  std::smatch match;
  const std::regex line(bag + ": ([0-9]+) keyframes");
  return std::regex_search(output, match, line) ? std::stoi(match[1]) : -1;
}

TEST(TrainPlaceModel, NewPlaceSamplesComeFromTheSampleBags) {
  const fs::path out = freshDir("samples");
  const auto run = train("--bags " + (kMission / "robot_a.bag").string() + " --sample-bags " +
                         (kMission / "robot_b.bag").string() + " --out " + out.string() +
                         " --iss-non-max-radius-m 0.75");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const int trained = keyframesOf(run.output, "robot_a.bag");
  const int sampled = keyframesOf(run.output, "robot_b.bag");
  ASSERT_GT(trained, 5) << run.output;
  ASSERT_GT(sampled, 5) << run.output;
  const auto model = core::place_recognition::PlaceModel::load(out.string());
  EXPECT_EQ(model->samples.size(), static_cast<std::size_t>(sampled));
  EXPECT_DOUBLE_EQ(model->features.iss_non_max_radius_m, 0.75);
  const YAML::Node about = YAML::LoadFile((out / "model.yaml").string());
  EXPECT_EQ(about["training_keyframes"].as<int>(), trained);
  EXPECT_EQ(about["sample_bags"][0].as<std::string>(), "robot_b.bag");
  fs::remove_all(out);
}

TEST(TrainPlaceModel, WithoutSampleBagsEverySecondKeyframeIsHeldOut) {
  const fs::path out = freshDir("split");
  const auto run =
      train("--bags " + (kMission / "robot_a.bag").string() + " --out " + out.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const int keyframes = keyframesOf(run.output, "robot_a.bag");
  ASSERT_GT(keyframes, 5) << run.output;
  const auto model = core::place_recognition::PlaceModel::load(out.string());
  EXPECT_EQ(model->samples.size(), static_cast<std::size_t>(keyframes / 2));
  EXPECT_EQ(YAML::LoadFile((out / "model.yaml").string())["training_keyframes"].as<int>(),
            keyframes - keyframes / 2);
  fs::remove_all(out);
}

TEST(TrainPlaceModel, RefusesBadFeatureSettings) {
  const auto run = train("--bags " + (kMission / "robot_a.bag").string() + " --out " +
                         freshDir("bad").string() + " --feature-drop-horizontal sideways");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("--feature-drop-horizontal"), std::string::npos) << run.output;
  const auto negative = train("--bags " + (kMission / "robot_a.bag").string() + " --out " +
                              freshDir("bad").string() + " --iss-non-max-radius-m -1");
  EXPECT_EQ(negative.exit_code, 2) << negative.output;
  EXPECT_NE(negative.output.find("iss_non_max_radius_m"), std::string::npos) << negative.output;
}

TEST(EvalFeatures, ReportsCountsAndRepeatabilityAboveChance) {
  // stdout only: PCL's ISS warns on stderr.
  const auto run = test::runCommand("(" + std::string(EVAL_FEATURES) + " --mission " +
                                    kMission.string() + " 2>/dev/null)");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const YAML::Node report = YAML::Load(run.output);  // JSON is YAML
  const YAML::Node source = report["sources"][0];
  EXPECT_GT(source["keyframes"].as<int>(), 10);
  EXPECT_GT(source["keypoints"]["mean"].as<double>(), 20.0);
  EXPECT_LE(source["descriptors"]["mean"].as<double>(), source["keypoints"]["mean"].as<double>());
  EXPECT_TRUE(source["words"].IsNull());  // no model given
  ASSERT_GT(source["revisits"].as<int>(), 0) << "the fixture's robots meet";
  // ISS picks corners and edges that both visits see; random points of the same count repeat
  // only by chance.
  EXPECT_GT(source["repeatability"].as<double>(), source["repeatability_by_chance"].as<double>());
  EXPECT_LE(source["repeatability"].as<double>(), 1.0);
}

TEST(EvalFeatures, RefusesFeatureFlagsWithAModel) {
  const auto run = test::runCommand(std::string(EVAL_FEATURES) + " --mission " + kMission.string() +
                                    " --model /any --feature-voxel-m 0.1");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_EQ(test::runCommand(EVAL_FEATURES).exit_code, 2);
}

}  // namespace
}  // namespace ccir_mapping
