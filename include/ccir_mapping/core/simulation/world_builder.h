// Builds the simulated worlds from their parameters and a seed.
#pragma once

#include <cstdint>

#include "ccir_mapping/core/simulation/world.h"
#include "ccir_mapping/core/simulation/world_params.h"

namespace ccir_mapping::core::simulation {

/// The world `params.world` names, with its road map and spatial index. The floor is at z = 0.
/// The same params and seed give the same world. Throws std::invalid_argument when
/// params.validate() reports errors.
World buildWorld(const WorldParams& params, std::uint64_t seed);

}  // namespace ccir_mapping::core::simulation
