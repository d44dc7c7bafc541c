// What the Params tests of every module ask of a validation error list.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

namespace ccir_mapping::core::testing {

/// Whether one of `errors` starts with `text` (each names its parameter first).
inline bool mentions(const std::vector<std::string>& errors, const std::string& text) {
  return std::any_of(errors.begin(), errors.end(),
                     [&](const std::string& e) { return e.rfind(text, 0) == 0; });
}

}  // namespace ccir_mapping::core::testing
