// Republishing what teammates send: each inbox topic is advertised on its first message, and a
// new topic holds its messages for a moment, so that subscribers in other processes have
// connected (roscpp connects them asynchronously) before the first ones go out. A message of
// another type than the topic's first is refused. `Sink` publishes a `MessagePtr` (the Bridge's
// ros::Publisher); thread-safe.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>

namespace ccir_mapping::core::transport {

template <class MessagePtr, class Sink>
class InboxPublishers {
 public:
  using Advertise =
      std::function<Sink(const std::string& topic, const MessagePtr& first, bool latched)>;

  InboxPublishers(Advertise advertise, double hold_s)
      : advertise_(std::move(advertise)), hold_s_(hold_s) {}

  /// Publishes (or holds) `message` of type `md5` on `topic` at `now_s`, the first one
  /// advertising the topic (latched or not); false, changing nothing, when the topic carries
  /// another type.
  bool publish(const std::string& topic, const std::string& md5, bool latched,
               const MessagePtr& message, double now_s) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = topics_.find(topic);
    if (it == topics_.end()) {
      Topic fresh{advertise_(topic, message, latched), md5, now_s + hold_s_, {}};
      it = topics_.emplace(topic, std::move(fresh)).first;
    }
    Topic& t = it->second;
    if (t.md5 != md5) return false;
    if (t.held.empty() && now_s >= t.ready_s) {
      t.sink.publish(message);
    } else {
      t.held.push_back(message);
    }
    return true;
  }

  /// Publishes, in order, what the topics whose hold has passed by `now_s` held.
  void flush(double now_s) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [name, t] : topics_) {
      if (now_s < t.ready_s) continue;
      for (const auto& message : t.held) t.sink.publish(message);
      t.held.clear();
    }
  }

 private:
  struct Topic {
    Sink sink;
    std::string md5;
    double ready_s = 0.0;
    std::deque<MessagePtr> held;
  };

  Advertise advertise_;
  double hold_s_;
  std::mutex mutex_;
  std::map<std::string, Topic> topics_;
};

}  // namespace ccir_mapping::core::transport
