// dynamic_reconfigure over a core Params struct, one entry per run-time key: the key's name, the
// member of the generated Config and the member of the core Params it sets. Bounds and defaults
// stay in the .cfg, checked against the core's validate() by test_reconfigure_bounds over the
// same entries.
#pragma once

#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace ccir_mapping::ros_params {

template <class Config, class Params>
class ReconfigureTable {
 public:
  struct Entry {
    std::string name;
    /// Copies the key from a Config into a Params.
    std::function<void(const Config&, Params&)> to_params;
    /// Copies the key from a Params into a Config.
    std::function<void(const Params&, Config&)> to_config;
    /// Appends " name before -> after" to `out` when the key differs between the two.
    std::function<void(const Params&, const Params&, std::ostream&)> note_change;
  };

  /// What one reconfigure request does.
  struct Outcome {
    /// The first validation error; `config` was then reset to the current values.
    std::optional<std::string> error;
    /// The new parameters (the current ones when refused).
    Params params;
    /// " name before -> after" for every key that changed; empty when none did.
    std::string changes;
  };

  template <class T>
  ReconfigureTable& add(std::string name, T Config::*config, T Params::*params) {
    auto note_change = [params, name](const Params& before, const Params& after,
                                      std::ostream& out) {
      if (before.*params != after.*params) {
        out << " " << name << " " << before.*params << " -> " << after.*params;
      }
    };
    entries_.push_back({std::move(name),
                        [config, params](const Config& c, Params& p) { p.*params = c.*config; },
                        [config, params](const Params& p, Config& c) { c.*config = p.*params; },
                        std::move(note_change)});
    return *this;
  }

  /// Applies the keys of `config` to a copy of `current` and validates it; a refused request
  /// resets `config` to `current`, so the server publishes what is in force.
  Outcome apply(Config& config, const Params& current) const {
    Outcome outcome{std::nullopt, current, {}};
    for (const Entry& e : entries_) e.to_params(config, outcome.params);
    const std::vector<std::string> errors = outcome.params.validate();
    if (!errors.empty()) {
      outcome.error = errors.front();
      outcome.params = current;
      for (const Entry& e : entries_) e.to_config(current, config);
      return outcome;
    }
    std::ostringstream changes;
    for (const Entry& e : entries_) e.note_change(current, outcome.params, changes);
    outcome.changes = changes.str();
    return outcome;
  }

  const std::vector<Entry>& entries() const { return entries_; }

 private:
  std::vector<Entry> entries_;
};

}  // namespace ccir_mapping::ros_params
