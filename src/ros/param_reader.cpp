#include "ccir_mapping/ros/param_reader.h"

#include <sstream>

namespace ccir_mapping::ros_params {

ParamReader::ParamReader(const XmlRpc::XmlRpcValue& values, std::string ns)
    : values_(values), ns_(std::move(ns)) {
  if (values_.getType() != XmlRpc::XmlRpcValue::TypeStruct &&
      values_.getType() != XmlRpc::XmlRpcValue::TypeInvalid) {
    errors_.push_back(ns_ + " is not a namespace of parameters");
    values_ = XmlRpc::XmlRpcValue();
  }
}

const XmlRpc::XmlRpcValue* ParamReader::find(const std::string& key) {
  known_.insert(key);
  if (values_.getType() != XmlRpc::XmlRpcValue::TypeStruct || !values_.hasMember(key)) {
    return nullptr;
  }
  return &values_[key];
}

const XmlRpc::XmlRpcValue* ParamReader::raw(const std::string& key) { return find(key); }

void ParamReader::typeError(const std::string& key, const char* expected) {
  errors_.push_back(key + " has the wrong type: expected " + expected);
}

void ParamReader::note(const std::string& key, const std::string& value) {
  effective_.emplace_back(key, value);
}

void ParamReader::read(const std::string& key, double& value) {
  if (const XmlRpc::XmlRpcValue* found = find(key)) {
    XmlRpc::XmlRpcValue v = *found;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      value = static_cast<double>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      value = static_cast<int>(v);
    } else {
      return typeError(key, "a number");
    }
  }
  std::ostringstream out;
  out << value;
  note(key, out.str());
}

void ParamReader::read(const std::string& key, int& value) {
  if (const XmlRpc::XmlRpcValue* found = find(key)) {
    XmlRpc::XmlRpcValue v = *found;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeInt) return typeError(key, "an integer");
    value = static_cast<int>(v);
  }
  note(key, std::to_string(value));
}

void ParamReader::read(const std::string& key, bool& value) {
  if (const XmlRpc::XmlRpcValue* found = find(key)) {
    XmlRpc::XmlRpcValue v = *found;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return typeError(key, "true or false");
    value = static_cast<bool>(v);
  }
  note(key, value ? "true" : "false");
}

void ParamReader::read(const std::string& key, std::string& value) {
  if (const XmlRpc::XmlRpcValue* found = find(key)) {
    XmlRpc::XmlRpcValue v = *found;
    if (v.getType() != XmlRpc::XmlRpcValue::TypeString) return typeError(key, "a string");
    value = static_cast<std::string>(v);
  }
  note(key, "'" + value + "'");
}

void ParamReader::addErrors(const std::vector<std::string>& errors) {
  errors_.insert(errors_.end(), errors.begin(), errors.end());
}

std::vector<std::string> ParamReader::unknownKeys() const {
  std::vector<std::string> unknown;
  if (values_.getType() != XmlRpc::XmlRpcValue::TypeStruct) return unknown;
  for (const auto& [key, value] : values_) {
    if (!known_.count(key)) unknown.push_back(key);
  }
  return unknown;
}

std::string ParamReader::summary() const {
  std::string text;
  for (const auto& [key, value] : effective_) {
    text += (text.empty() ? "" : ", ") + key + "=" + value;
  }
  return text;
}

}  // namespace ccir_mapping::ros_params
