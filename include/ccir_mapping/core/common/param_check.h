// Collects parameter validation errors, each naming the parameter and what is allowed.
#pragma once

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace ccir_mapping::core {

/// Accumulates human-readable errors such as
/// "voxel_leaf_m = -1 is out of range: allowed [0.01, 5]".
class ParamCheck {
 public:
  /// lo <= value <= hi.
  void inRange(std::string_view name, double value, double lo, double hi);
  /// lo < value <= hi.
  void inHalfOpenRange(std::string_view name, double value, double lo, double hi);
  /// A ROS-name-safe robot name: a letter, then letters, digits or '_'.
  void robotName(std::string_view name, const std::string& value);
  /// Adds an error when `condition` is false.
  void require(bool condition, std::string message);

  bool ok() const { return errors_.empty(); }
  const std::vector<std::string>& errors() const { return errors_; }

 private:
  std::vector<std::string> errors_;
};

/// The message a loader reports for a value that is not one of `choices` (e.g. "ccir |
/// fixed_rate").
std::string notOneOf(std::string_view name, std::string_view value, std::string_view choices);

/// True for a name usable as a robot name and frame prefix ("robot_a").
bool isValidRobotName(std::string_view name);

/// `params` itself when params.validate() reports nothing; otherwise throws
/// std::invalid_argument with the first error (which names the parameter).
template <class Params>
const Params& validated(const Params& params) {
  const std::vector<std::string> errors = params.validate();
  if (!errors.empty()) throw std::invalid_argument(errors.front());
  return params;
}

}  // namespace ccir_mapping::core
