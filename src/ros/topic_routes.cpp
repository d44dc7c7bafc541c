#include "ccir_mapping/ros/topic_routes.h"

#include <ros/names.h>

#include "ccir_mapping/ros/topics.h"

namespace ccir_mapping::topics {

namespace {

constexpr char kOutboxPrefix[] = "outbox/";
constexpr char kInboxPrefix[] = "inbox/";

/// X of "<prefix>X", or nullopt.
std::optional<std::string> after(const std::string& name, const std::string& prefix) {
  if (name.rfind(prefix, 0) != 0 || name.size() == prefix.size()) return std::nullopt;
  return name.substr(prefix.size());
}

}  // namespace

std::vector<OutboxRoute> outboxRoutes(const std::string& forwarded,
                                      const std::vector<std::string>& peers) {
  std::vector<OutboxRoute> routes{{forwarded, ""}};
  const auto rest = after(forwarded, kOutboxPrefix);
  if (!rest) return routes;
  for (const std::string& peer : peers) routes.push_back({outboxTo(peer, *rest), peer});
  return routes;
}

std::string inboxOf(const std::string& forwarded) {
  return kInboxPrefix + after(forwarded, kOutboxPrefix).value_or(forwarded);
}

std::optional<std::vector<std::string>> inboxRepublished(const std::string& inbox,
                                                         const std::string& peer,
                                                         std::string* error) {
  const auto rest = after(inbox, kInboxPrefix);
  if (!rest || inbox.find("..") != std::string::npos || !ros::names::validate(inbox, *error)) {
    if (error->empty()) *error = "not a topic under " + std::string(kInboxPrefix);
    return std::nullopt;
  }
  const std::string by_peer = kInboxPrefix + peer + "/" + *rest;
  if (!ros::names::validate(by_peer, *error)) return std::nullopt;
  return std::vector<std::string>{inbox, by_peer};
}

}  // namespace ccir_mapping::topics
