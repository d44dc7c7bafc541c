// A robot's occupancy map shared between the nodelets of its manager: the Mapper writes it, the
// Broker asks it information questions in-process (no copy over a topic). Readers take a shared
// lock for the duration of a query; the Mapper changes it under the exclusive lock, so a query
// never sees a scan or a moved submap half applied. The nodelets meet through a registry of the
// process
// keyed by the Mapper nodelet's name, which the Broker's `mapper` parameter names.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>

#include "ccir_mapping/core/information/occupancy_map.h"

namespace ccir_mapping::core::information {

class SharedMap {
 public:
  explicit SharedMap(std::unique_ptr<OccupancyMap> map) : map_(std::move(map)) {}

  template <class F>
  auto read(F&& f) const {
    std::shared_lock lock(mutex_);
    return f(static_cast<const OccupancyMap&>(*map_));
  }
  template <class F>
  auto write(F&& f) {
    std::unique_lock lock(mutex_);
    return f(*map_);
  }

  /// The maps of this process by the (resolved) name of the Mapper nodelet that writes it.
  static void registerMap(const std::string& mapper, const std::shared_ptr<SharedMap>& map) {
    std::lock_guard lock(registryMutex());
    registry()[mapper] = map;
  }
  /// Null while no Mapper of that name runs in this process.
  static std::shared_ptr<SharedMap> find(const std::string& mapper) {
    std::lock_guard lock(registryMutex());
    const auto it = registry().find(mapper);
    return it == registry().end() ? nullptr : it->second.lock();
  }

 private:
  static std::map<std::string, std::weak_ptr<SharedMap>>& registry() {
    static std::map<std::string, std::weak_ptr<SharedMap>> maps;
    return maps;
  }
  static std::mutex& registryMutex() {
    static std::mutex mutex;
    return mutex;
  }

  mutable std::shared_mutex mutex_;
  std::unique_ptr<OccupancyMap> map_;
};

}  // namespace ccir_mapping::core::information
