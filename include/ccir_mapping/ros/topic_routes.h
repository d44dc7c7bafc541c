// How the Bridge names what it carries: "outbox/X" goes to every teammate and
// "outbox/to/<peer>/X" to that teammate alone (topics::outboxTo), both arriving as "inbox/X"; a
// teammate's message on "inbox/X" is republished there and on "inbox/<peer>/X".
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace ccir_mapping::topics {

/// An outbox topic the Bridge subscribes to, and the teammate it is for ("": every teammate).
struct OutboxRoute {
  std::string outbox;
  std::string peer;
};
/// The outbox topics of forwarded topic "outbox/X": itself, and "outbox/to/<peer>/X" for each
/// teammate.
std::vector<OutboxRoute> outboxRoutes(const std::string& forwarded,
                                      const std::vector<std::string>& peers);

/// "inbox/X", where teammates republish forwarded topic "outbox/X".
std::string inboxOf(const std::string& forwarded);

/// The topics a teammate's message on `inbox` is republished on: `inbox` itself and
/// "inbox/<peer>/X"; nullopt when `inbox` is not a valid topic name under "inbox/" (a peer's
/// claim is not trusted), with why in `error`.
std::optional<std::vector<std::string>> inboxRepublished(const std::string& inbox,
                                                         const std::string& peer,
                                                         std::string* error);

}  // namespace ccir_mapping::topics
