// What one bridge link sends next: strict priority classes (control before bulk), a queue policy
// per topic (FIFO or keep-latest, bounded, with a maximum age), large messages cut into
// fragments so a control message waits at most one fragment, and a token bucket on the bytes
// that reach the wire (frame headers and MACs included).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ccir_mapping/core/transport/bridge_params.h"
#include "ccir_mapping/core/transport/frame_codec.h"
#include "ccir_mapping/core/transport/token_bucket.h"

namespace ccir_mapping::core::transport {

struct LinkCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t bytes_sent = 0;  // on the wire
  std::uint64_t messages_sent = 0;
  std::uint64_t dropped_queue_full = 0;
  std::uint64_t dropped_expired = 0;
  std::uint64_t replaced = 0;  // keep-latest: a newer message took its place
};

class LinkScheduler {
 public:
  /// Throws std::invalid_argument for a non-positive rate, burst or fragment size, or a
  /// fragment whose frame would not fit in the burst.
  LinkScheduler(double rate_bytes_per_s, std::size_t burst_bytes, std::size_t fragment_bytes,
                double now_s);

  void setTopic(std::uint16_t topic, const TopicPolicy& policy);
  /// A second bucket this link shares with others (the bridge's total budget): a frame leaves
  /// only when both buckets hold its bytes.
  void shareBucket(std::shared_ptr<TokenBucket> total) { total_ = std::move(total); }
  /// Queues a serialised message of a topic set before (else std::invalid_argument); returns
  /// the sequence number it will carry (per topic, from 1). A message sent again after a
  /// reconnect keeps its `sequence` and, on a fifo topic, is neither counted against its
  /// max_queued nor dropped for a newer message (what waits to be sent again is bounded where it
  /// is kept); `type` is that of all its frames.
  std::uint64_t enqueue(std::uint16_t topic, std::vector<std::uint8_t> message, double now_s,
                        FrameType type = FrameType::kData,
                        std::optional<std::uint64_t> sequence = std::nullopt);
  /// The topic's next sequence number, for a message kept to be sent later (enqueue it with it).
  std::uint64_t nextSequence(std::uint16_t topic);
  /// Forgets everything queued or half-sent (the connection it was for is gone).
  void clear();

  /// The next frame to send at `now_s`, or nullopt when nothing is queued or the bucket has too
  /// few tokens (see delay()).
  std::optional<Frame> next(double now_s);
  /// Seconds until next() can send (0 if it can now), or infinity when nothing is queued.
  double delay(double now_s);

  /// Messages of a class not yet sent whole (waiting, and the one whose fragments are going).
  std::size_t queued(Priority priority) const;
  /// Their bytes still to send (payload, without frame overhead).
  std::size_t queuedBytes(Priority priority) const;
  /// Bytes that could leave now: the tokens in this link's bucket, and in the shared one.
  double availableTokens(double now_s) const;
  const LinkCounters& counters() const { return counters_; }

 private:
  struct Message {
    std::uint16_t topic;
    FrameType type;
    std::uint64_t sequence;
    double enqueued_s;
    std::vector<std::uint8_t> bytes;
    bool sent_again = false;
  };
  struct Topic {
    TopicPolicy policy;
    std::uint64_t last_sequence = 0;
  };

  void dropExpired(double now_s);
  /// The class that sends next: one with fragments in flight or queued messages, control first.
  std::optional<Priority> nextClass() const;
  /// Starts the oldest message of a class: its fragments become the class's in-flight frames.
  void start(Priority priority);

  TokenBucket bucket_;
  std::shared_ptr<TokenBucket> total_;
  std::size_t fragment_bytes_;
  std::map<std::uint16_t, Topic> topics_;
  /// Per class: waiting messages in arrival order, and the fragments of the one being sent.
  std::map<Priority, std::deque<Message>> waiting_;
  std::map<Priority, std::deque<Frame>> in_flight_;
  LinkCounters counters_;
};

}  // namespace ccir_mapping::core::transport
