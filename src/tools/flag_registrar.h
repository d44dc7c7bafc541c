// Command-line flags made from a Params struct's field list (`Params::fields(params, visitor)`):
// one flag per field, named after it with '-' for '_', showing its unit, range and default.
#pragma once

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include <boost/program_options.hpp>

#include "ccir_mapping/core/common/field_check.h"

namespace ccir_mapping::tools {

inline std::string flagName(const std::string& name) {
  std::string flag = name;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

template <class T>
inline std::string text(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// Adds one flag per parameter field, named after the field with '-' for '_'.
class FlagRegistrar {
 public:
  explicit FlagRegistrar(boost::program_options::options_description* options)
      : options_(options) {}

  void number(const char* name, double& field, const char* unit, double lo, double hi,
              const char* help) {
    add(name,
        boost::program_options::value<double>(&field)
            ->default_value(field, text(field))
            ->value_name(*unit ? unit : "x"),
        describe(help, unit, text(lo) + " .. " + text(hi)));
  }
  void integer(const char* name, int& field, const char* unit, int lo, int hi, const char* help) {
    add(name,
        boost::program_options::value<int>(&field)->default_value(field)->value_name(*unit ? unit
                                                                                           : "n"),
        describe(help, unit, text(lo) + " .. " + text(hi)));
  }
  void flag(const char* name, bool& field, const char* help) {
    add(name, boost::program_options::bool_switch(&field), help);
  }
  void choice(const char* name, std::string& field, const std::vector<std::string>& choices,
              const char* help) {
    add(name,
        boost::program_options::value<std::string>(&field)->default_value(field)->value_name(
            "name"),
        describe(help, "", ccir_mapping::core::joinChoices(choices)));
  }

 private:
  static std::string describe(const char* help, const char* unit, const std::string& allowed) {
    std::string out = help;
    if (*unit) out += std::string(" [") + unit + "]";
    return out + "; allowed " + allowed;
  }
  void add(const char* name, const boost::program_options::value_semantic* semantic,
           const std::string& help) {
    options_->add_options()(flagName(name).c_str(), semantic, help.c_str());
  }
  boost::program_options::options_description* options_;
};

}  // namespace ccir_mapping::tools
