// Validates a Params struct that lists its fields through a visitor (see
// core/simulation/mission_params.h): one list gives validation, command-line flags and files.
#pragma once

#include <string>
#include <vector>

#include "ccir_mapping/core/common/param_check.h"

namespace ccir_mapping::core {

/// A field visitor that checks each field against the range or choices it is listed with.
class FieldCheck {
 public:
  void number(const char* name, double value, const char* /*unit*/, double lo, double hi,
              const char* /*help*/) {
    check_.inRange(name, value, lo, hi);
  }
  void integer(const char* name, int value, const char* /*unit*/, int lo, int hi,
               const char* /*help*/) {
    check_.inRange(name, value, lo, hi);
  }
  void flag(const char* /*name*/, bool /*value*/, const char* /*help*/) {}
  void choice(const char* name, const std::string& value, const std::vector<std::string>& choices,
              const char* /*help*/);

  ParamCheck& check() { return check_; }

 private:
  ParamCheck check_;
};

/// "a | b | c".
std::string joinChoices(const std::vector<std::string>& choices);

}  // namespace ccir_mapping::core
