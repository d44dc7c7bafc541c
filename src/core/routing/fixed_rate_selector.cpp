#include "ccir_mapping/core/routing/fixed_rate_selector.h"

namespace ccir_mapping::core::routing {

bool FixedRateSelector::select() { return offered_++ % static_cast<std::uint64_t>(every_n_) == 0; }

}  // namespace ccir_mapping::core::routing
