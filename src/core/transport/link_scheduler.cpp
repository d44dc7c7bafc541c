#include "ccir_mapping/core/transport/link_scheduler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ccir_mapping/core/transport/message_fragments.h"

namespace ccir_mapping::core::transport {

LinkScheduler::LinkScheduler(double rate_bytes_per_s, std::size_t burst_bytes,
                             std::size_t fragment_bytes, double now_s)
    : bucket_(rate_bytes_per_s, static_cast<double>(burst_bytes), now_s),
      fragment_bytes_(fragment_bytes) {
  if (fragment_bytes == 0 || wireBytes(fragment_bytes) > burst_bytes) {
    throw std::invalid_argument(
        "LinkScheduler: fragment_bytes must be positive and a fragment's "
        "frame must fit in burst_bytes");
  }
}

void LinkScheduler::setTopic(std::uint16_t topic, const TopicPolicy& policy) {
  topics_[topic].policy = policy;
}

std::uint64_t LinkScheduler::enqueue(std::uint16_t topic, std::vector<std::uint8_t> message,
                                     double now_s, FrameType type,
                                     std::optional<std::uint64_t> sequence) {
  const auto it = topics_.find(topic);
  if (it == topics_.end()) throw std::invalid_argument("LinkScheduler: unknown topic");
  Topic& t = it->second;
  auto& queue = waiting_[t.policy.priority];
  const auto same_topic = [topic](const Message& m) { return m.topic == topic; };
  const auto same_topic_new = [topic](const Message& m) {
    return m.topic == topic && !m.sent_again;
  };
  if (t.policy.queue == QueuePolicy::kKeepLatest) {
    const auto before = queue.size();
    queue.erase(std::remove_if(queue.begin(), queue.end(), same_topic), queue.end());
    counters_.replaced += before - queue.size();
  } else if (!sequence && static_cast<std::size_t>(std::count_if(
                              queue.begin(), queue.end(), same_topic_new)) >= t.policy.max_queued) {
    queue.erase(std::find_if(queue.begin(), queue.end(), same_topic_new));
    ++counters_.dropped_queue_full;
  }
  const std::uint64_t seq = sequence ? *sequence : ++t.last_sequence;
  queue.push_back({topic, type, seq, now_s, std::move(message), sequence.has_value()});
  return seq;
}

std::uint64_t LinkScheduler::nextSequence(std::uint16_t topic) {
  const auto it = topics_.find(topic);
  if (it == topics_.end()) throw std::invalid_argument("LinkScheduler: unknown topic");
  return ++it->second.last_sequence;
}

void LinkScheduler::dropExpired(double now_s) {
  for (auto& [priority, queue] : waiting_) {
    const auto before = queue.size();
    queue.erase(std::remove_if(queue.begin(), queue.end(),
                               [&](const Message& m) {
                                 const double max_age = topics_.at(m.topic).policy.max_age_s;
                                 return max_age > 0 && now_s - m.enqueued_s > max_age;
                               }),
                queue.end());
    counters_.dropped_expired += before - queue.size();
  }
}

std::optional<Priority> LinkScheduler::nextClass() const {
  for (const Priority p : {Priority::kControl, Priority::kBulk}) {
    const auto f = in_flight_.find(p);
    const auto w = waiting_.find(p);
    if ((f != in_flight_.end() && !f->second.empty()) ||
        (w != waiting_.end() && !w->second.empty())) {
      return p;
    }
  }
  return std::nullopt;
}

void LinkScheduler::start(Priority priority) {
  auto& frames = in_flight_[priority];
  auto& queue = waiting_[priority];
  if (!frames.empty() || queue.empty()) return;
  const Message& m = queue.front();
  for (auto& f : fragmentMessage(m.topic, m.sequence, m.bytes, fragment_bytes_)) {
    f.type = m.type;
    frames.push_back(std::move(f));
  }
  queue.pop_front();
}

double LinkScheduler::delay(double now_s) {
  dropExpired(now_s);
  const auto priority = nextClass();
  if (!priority) return std::numeric_limits<double>::infinity();
  start(*priority);
  const std::size_t bytes = wireBytes(in_flight_[*priority].front().payload.size());
  const double link = bucket_.delayFor(bytes, now_s);
  return total_ ? std::max(link, total_->delayFor(bytes, now_s)) : link;
}

std::optional<Frame> LinkScheduler::next(double now_s) {
  if (std::isinf(delay(now_s))) return std::nullopt;  // (also readies the next fragment)
  auto& frames = in_flight_[*nextClass()];
  const std::size_t bytes = wireBytes(frames.front().payload.size());
  if (!bucket_.canConsume(bytes, now_s) || (total_ && !total_->canConsume(bytes, now_s))) {
    return std::nullopt;
  }
  bucket_.tryConsume(bytes, now_s);
  if (total_) total_->tryConsume(bytes, now_s);
  Frame frame = std::move(frames.front());
  frames.pop_front();
  ++counters_.frames_sent;
  counters_.bytes_sent += bytes;
  counters_.messages_sent += frame.fragment + 1 == frame.fragments;
  return frame;
}

void LinkScheduler::clear() {
  waiting_.clear();
  in_flight_.clear();
}

std::size_t LinkScheduler::queued(Priority priority) const {
  const auto waiting = waiting_.find(priority);
  const auto in_flight = in_flight_.find(priority);
  return (waiting == waiting_.end() ? 0 : waiting->second.size()) +
         (in_flight == in_flight_.end() || in_flight->second.empty() ? 0 : 1);
}

std::size_t LinkScheduler::queuedBytes(Priority priority) const {
  std::size_t bytes = 0;
  if (const auto waiting = waiting_.find(priority); waiting != waiting_.end()) {
    for (const Message& message : waiting->second) bytes += message.bytes.size();
  }
  if (const auto in_flight = in_flight_.find(priority); in_flight != in_flight_.end()) {
    for (const Frame& frame : in_flight->second) bytes += frame.payload.size();
  }
  return bytes;
}

double LinkScheduler::availableTokens(double now_s) const {
  const double own = bucket_.tokens(now_s);
  return total_ ? std::min(own, total_->tokens(now_s)) : own;
}

}  // namespace ccir_mapping::core::transport
