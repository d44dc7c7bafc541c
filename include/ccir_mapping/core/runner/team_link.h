// One direction of a link between two robots in simulated time: the Bridge's LinkScheduler (the
// six outbox topics with its default policies: control before scans, FIFO, reliable; fragments;
// the link's token bucket and the sender's total one) over a LinkEmulator (the radio's rate,
// delay, jitter and losses). Messages cross as frames of their serialised size; the message
// itself is handed over when its last frame arrives.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "ccir_mapping/core/routing/routing_messages.h"
#include "ccir_mapping/core/runner/team_message.h"
#include "ccir_mapping/core/testing/link_emulator.h"
#include "ccir_mapping/core/transport/bridge_params.h"
#include "ccir_mapping/core/transport/link_scheduler.h"

namespace ccir_mapping::core::runner {

struct Delivery {
  double arrival_s = 0.0;
  TeamMessage message;
};

class TeamLink {
 public:
  /// `total` is the sender's bucket over all its links (null: none).
  TeamLink(const transport::BridgeParams& bridge, const testing::LinkEmulatorParams& radio,
           std::shared_ptr<transport::TokenBucket> total, double now_s);

  void enqueue(TeamMessage message, double now_s);
  /// Seconds until the next frame can leave (0: now), infinity when nothing is queued.
  double delay(double now_s) { return scheduler_.delay(now_s); }
  /// Sends the next frame at `now_s` if the buckets let it; the message it completes, if any,
  /// with its arrival time. False when no frame left.
  bool sendNext(double now_s, std::optional<Delivery>* completed);
  /// What LinkStats would report now (connected as the caller says).
  routing::LinkState state(bool connected, double now_s) const;
  const transport::LinkCounters& counters() const { return scheduler_.counters(); }
  double budgetBytesPerS() const { return budget_; }

 private:
  transport::LinkScheduler scheduler_;
  testing::LinkEmulator radio_;
  double budget_;
  double total_budget_;
  /// Messages queued or in flight, by topic and sequence.
  std::map<std::pair<int, std::uint64_t>, TeamMessage> queued_;
};

}  // namespace ccir_mapping::core::runner
