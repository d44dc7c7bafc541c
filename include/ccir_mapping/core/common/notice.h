// Something a core stage tells its caller to report (a refusal, a dropped input, an oddity),
// so that wording and decision live in the core and the nodelet only logs.
#pragma once

#include <string>

namespace ccir_mapping::core {

struct Notice {
  /// Groups notices for throttled logging: one kind's flood must not hide another kind.
  std::string kind;
  /// What happened and why.
  std::string text;
};

}  // namespace ccir_mapping::core
