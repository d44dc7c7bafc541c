#include "ccir_mapping/core/common/param_check.h"

#include <cctype>
#include <cmath>
#include <sstream>

namespace ccir_mapping::core {
namespace {

std::string outOfRange(std::string_view name, double value, char open, double lo, double hi) {
  std::ostringstream out;
  out << name << " = " << value << " is out of range: allowed " << open << lo << ", " << hi << "]";
  return out.str();
}

}  // namespace

void ParamCheck::inRange(std::string_view name, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi)) errors_.push_back(outOfRange(name, value, '[', lo, hi));
}

void ParamCheck::inHalfOpenRange(std::string_view name, double value, double lo, double hi) {
  if (!(value > lo && value <= hi)) errors_.push_back(outOfRange(name, value, '(', lo, hi));
}

void ParamCheck::robotName(std::string_view name, const std::string& value) {
  if (!isValidRobotName(value)) {
    errors_.push_back(std::string(name) + " = '" + value +
                      "' is not a valid robot name: allowed a letter followed by letters, "
                      "digits or '_'");
  }
}

void ParamCheck::require(bool condition, std::string message) {
  if (!condition) errors_.push_back(std::move(message));
}

std::string notOneOf(std::string_view name, std::string_view value, std::string_view choices) {
  std::ostringstream out;
  out << name << " = '" << value << "' is not allowed: allowed " << choices;
  return out.str();
}

bool isValidRobotName(std::string_view name) {
  if (name.empty() || !std::isalpha(static_cast<unsigned char>(name.front()))) return false;
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

}  // namespace ccir_mapping::core
