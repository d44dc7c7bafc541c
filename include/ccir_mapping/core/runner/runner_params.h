// Parameters of a team run in simulated time (core/runner/team_runner.h): the mission, each
// stage's own Params (the nodelets' defaults, one struct each), the links and how time advances.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "ccir_mapping/core/backend/backend_params.h"
#include "ccir_mapping/core/information/mapper_params.h"
#include "ccir_mapping/core/place_recognition/matcher_params.h"
#include "ccir_mapping/core/preprocess/preprocessor_params.h"
#include "ccir_mapping/core/routing/broker_params.h"
#include "ccir_mapping/core/simulation/mission_params.h"
#include "ccir_mapping/core/testing/link_emulator.h"
#include "ccir_mapping/core/transport/bridge_params.h"

namespace ccir_mapping::core::runner {

/// Which robots are linked: every pair for the whole mission, or a pair only while the two are
/// within radio range of each other.
enum class Topology { kAllPairs, kRadioRange };
constexpr std::string_view kTopologyChoices = "all_pairs | radio_range";
std::optional<Topology> parseTopology(std::string_view text);
const char* toString(Topology topology);

struct RunnerParams {
  simulation::MissionParams mission;
  preprocess::PreprocessorParams preprocessor;
  place_recognition::MatcherParams matcher;
  backend::BackendParams backend;
  information::MapperParams mapper;
  routing::BrokerParams broker;
  /// The link budgets, burst and fragment size and the LinkStats period (peers, ports and keys
  /// are not used: there are no sockets).
  transport::BridgeParams bridge;
  /// The radio under the budget: its rate, delay, jitter and losses (seeded per link from it).
  testing::LinkEmulatorParams radio;

  Topology topology = Topology::kAllPairs;
  /// radio_range: two robots are linked while their true positions are at most this far apart.
  double radio_range_m = 50.0;
  /// radio_range: ... and no wall or solid of the world is between them.
  bool radio_needs_line_of_sight = false;
  /// radio_range: the most teammates a robot is linked with at once; pairs are linked nearest
  /// first while both have fewer. 0: no bound.
  int max_peers = 8;

  /// Mission time advances in steps of this length; a message sent during a step is handled by
  /// its receiver from the next step on (so robots can run in parallel without seeing each
  /// other's step), which adds up to one step to every link's delay.
  double step_s = 0.1;
  /// Period of the time series (bytes per link, map volume and entropy, transform errors).
  double series_period_s = 1.0;

  /// Every error, each starting with the parameter's name; the stages' own checks included.
  std::vector<std::string> validate() const;
};

}  // namespace ccir_mapping::core::runner
