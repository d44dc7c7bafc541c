#include "ccir_mapping/core/common/field_check.h"

#include <algorithm>

namespace ccir_mapping::core {

void FieldCheck::choice(const char* name, const std::string& value,
                        const std::vector<std::string>& choices, const char* /*help*/) {
  if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
    check_.require(false, notOneOf(name, value, joinChoices(choices)));
  }
}

std::string joinChoices(const std::vector<std::string>& choices) {
  std::string out;
  for (const auto& c : choices) out += (out.empty() ? "" : " | ") + c;
  return out;
}

}  // namespace ccir_mapping::core
