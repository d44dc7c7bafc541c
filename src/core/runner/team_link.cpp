#include "ccir_mapping/core/runner/team_link.h"

namespace ccir_mapping::core::runner {

TeamLink::TeamLink(const transport::BridgeParams& bridge, const testing::LinkEmulatorParams& radio,
                   std::shared_ptr<transport::TokenBucket> total, double now_s)
    : scheduler_(bridge.budget_bytes_per_s, static_cast<std::size_t>(bridge.burst_bytes),
                 static_cast<std::size_t>(bridge.fragment_bytes), now_s),
      radio_(radio),
      budget_(bridge.budget_bytes_per_s),
      total_budget_(bridge.total_budget_bytes_per_s) {
  for (int topic = 0; topic < kTeamTopics; ++topic) {
    transport::TopicPolicy policy;  // the Bridge's default for the outbox topics
    policy.priority = isBulk(topic) ? transport::Priority::kBulk : transport::Priority::kControl;
    scheduler_.setTopic(static_cast<std::uint16_t>(topic), policy);
  }
  if (total) scheduler_.shareBucket(std::move(total));
}

void TeamLink::enqueue(TeamMessage message, double now_s) {
  const int topic = topicOf(message);
  // The bytes stand for the serialised message: only their number matters on the link.
  const std::uint64_t sequence =
      scheduler_.enqueue(static_cast<std::uint16_t>(topic),
                         std::vector<std::uint8_t>(serializedBytes(message)), now_s);
  queued_.emplace(std::make_pair(topic, sequence), std::move(message));
}

bool TeamLink::sendNext(double now_s, std::optional<Delivery>* completed) {
  completed->reset();
  const auto frame = scheduler_.next(now_s);
  if (!frame) return false;
  const double arrival = radio_.arrival(transport::wireBytes(frame->payload.size()), now_s);
  if (frame->fragment + 1 < frame->fragments) return true;
  const std::pair<int, std::uint64_t> key{frame->topic, frame->sequence};
  const auto it = queued_.find(key);
  if (it != queued_.end()) *completed = Delivery{arrival, std::move(it->second)};
  // Messages of the topic queued before it and not sent were dropped by the queue's bound.
  queued_.erase(queued_.lower_bound({frame->topic, 0}), queued_.upper_bound(key));
  return true;
}

routing::LinkState TeamLink::state(bool connected, double now_s) const {
  routing::LinkState s;
  s.connected = connected;
  s.budget_bytes_per_s = budget_;
  s.total_budget_bytes_per_s = total_budget_;
  s.queued_control_bytes = scheduler_.queuedBytes(transport::Priority::kControl);
  s.queued_bulk_bytes = scheduler_.queuedBytes(transport::Priority::kBulk);
  s.available_tokens_bytes = scheduler_.availableTokens(now_s);
  return s;
}

}  // namespace ccir_mapping::core::runner
