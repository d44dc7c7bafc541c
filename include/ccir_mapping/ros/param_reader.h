// Reads typed parameters from one namespace of the parameter server, given as an XmlRpc struct
// (the whole private namespace of a nodelet, or a section of a YAML file in tests).
#pragma once

#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <xmlrpcpp/XmlRpcValue.h>

namespace ccir_mapping::ros_params {

class ParamReader {
 public:
  /// `values` must be a struct, or invalid/empty for "no parameters set".
  explicit ParamReader(const XmlRpc::XmlRpcValue& values, std::string ns = "~");

  /// Each `read` leaves `value` (the default) unchanged when the key is absent, records an error
  /// naming the key when it has the wrong type, and records the effective value.
  void read(const std::string& key, double& value);
  void read(const std::string& key, int& value);
  void read(const std::string& key, bool& value);
  void read(const std::string& key, std::string& value);

  /// Reads a string and converts it with `parse` (returning std::optional<Enum>); an unknown
  /// value records an error listing `choices`.
  template <class Enum, class Parse>
  void readChoice(const std::string& key, Enum& value, Parse parse, std::string_view choices,
                  const char* (*to_string)(Enum));

  /// The raw value of a key (lists of structs); nullptr when absent. Marks the key as known.
  const XmlRpc::XmlRpcValue* raw(const std::string& key);

  void addError(std::string error) { errors_.push_back(std::move(error)); }
  /// Appends validation errors of the core Params struct.
  void addErrors(const std::vector<std::string>& errors);

  const std::vector<std::string>& errors() const { return errors_; }
  /// Keys present in the namespace that no `read` asked for: likely typos.
  std::vector<std::string> unknownKeys() const;
  /// "key=value, ..." of every parameter read, for one start-up log line.
  std::string summary() const;
  /// Every parameter read with its value as summary() shows it, in the order read.
  const std::vector<std::pair<std::string, std::string>>& effective() const { return effective_; }
  /// Every key asked for, read or raw.
  const std::set<std::string>& knownKeys() const { return known_; }
  const std::string& ns() const { return ns_; }

 private:
  const XmlRpc::XmlRpcValue* find(const std::string& key);
  void typeError(const std::string& key, const char* expected);
  void note(const std::string& key, const std::string& value);

  XmlRpc::XmlRpcValue values_;
  std::string ns_;
  std::set<std::string> known_;
  std::vector<std::string> errors_;
  std::vector<std::pair<std::string, std::string>> effective_;
};

template <class Enum, class Parse>
void ParamReader::readChoice(const std::string& key, Enum& value, Parse parse,
                             std::string_view choices, const char* (*to_string)(Enum)) {
  std::string text = to_string(value);
  const std::size_t errors_before = errors_.size();
  read(key, text);
  if (errors_.size() != errors_before) return;
  if (const auto parsed = parse(text)) {
    value = *parsed;
  } else {
    addError(key + " = '" + text + "' is not allowed: allowed " + std::string(choices));
  }
}

}  // namespace ccir_mapping::ros_params
