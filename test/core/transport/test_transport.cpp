// Bridge transport (algorithms.md section 7.5): the token bucket never lets more than
// burst + rate * dt bytes through in any window; frames round-trip, streamed in any pieces;
// corrupt, truncated, foreign-key and random input is refused by reason and never crashes;
// fragments reassemble in any order within bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <numeric>
#include <random>
#include <tuple>

#include "ccir_mapping/core/common/compression.h"
#include "ccir_mapping/core/testing/link_emulator.h"
#include "ccir_mapping/core/transport/frame_codec.h"
#include "ccir_mapping/core/transport/inbox_publishers.h"
#include "ccir_mapping/core/transport/link_scheduler.h"
#include "ccir_mapping/core/transport/message_fragments.h"
#include "ccir_mapping/core/transport/peer_session.h"
#include "ccir_mapping/core/transport/reliable_outbox.h"
#include "ccir_mapping/core/transport/sequence_filter.h"
#include "ccir_mapping/core/transport/token_bucket.h"
#include "numbered_bytes.h"

namespace ccir_mapping::core::transport {
namespace {

using testing::LinkEmulator;
using testing::LinkEmulatorParams;

TEST(TokenBucket, NoWindowCarriesMoreThanBurstPlusRateTimesItsLength) {
  const double rate = 150000.0;
  const double burst = 65536.0;
  TokenBucket bucket(rate, burst, 0.0);
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> size(1, 70000);
  std::exponential_distribution<double> gap(2000.0);
  std::vector<std::pair<double, std::size_t>> sent;  // (time, bytes)
  double t = 0.0;
  std::size_t total = 0;
  while (t < 20.0) {
    t += gap(rng);
    const auto bytes = static_cast<std::size_t>(size(rng));
    if (bucket.tryConsume(bytes, t)) {
      sent.emplace_back(t, bytes);
      total += bytes;
    }
  }
  // The link was saturated: about rate * 20 s went through.
  EXPECT_GT(total, 0.9 * rate * 20.0);
  // Every window [sent[i].t, sent[j].t]: at most burst + rate * dt.
  for (std::size_t i = 0; i < sent.size(); ++i) {
    std::size_t bytes = 0;
    for (std::size_t j = i; j < sent.size(); ++j) {
      bytes += sent[j].second;
      ASSERT_LE(bytes, burst + rate * (sent[j].first - sent[i].first) + 1e-6)
          << "window " << sent[i].first << " .. " << sent[j].first;
    }
  }
  EXPECT_FALSE(bucket.tryConsume(70000, t + 100.0)) << "above the burst never passes";
  EXPECT_TRUE(std::isinf(bucket.delayFor(70000, t)));
  EXPECT_EQ(TokenBucket(1000.0, 500.0, 0.0).delayFor(300, 0.0), 0.0) << "a full bucket";
  TokenBucket empty(1000.0, 500.0, 0.0);
  ASSERT_TRUE(empty.tryConsume(500, 0.0));
  EXPECT_NEAR(empty.delayFor(250, 0.0), 0.25, 1e-12);
  EXPECT_FALSE(empty.tryConsume(250, 0.2));
  EXPECT_TRUE(empty.tryConsume(250, 0.25));
  EXPECT_THROW(TokenBucket(0.0, 10.0, 0.0), std::invalid_argument);
}

Frame sampleFrame(std::size_t payload_bytes, std::uint64_t sequence = 7) {
  Frame f;
  f.type = FrameType::kData;
  f.flags = 2;
  f.topic = 3;
  f.sequence = sequence;
  for (std::size_t i = 0; i < payload_bytes; ++i) {
    f.payload.push_back(static_cast<std::uint8_t>(i * 31 + sequence));
  }
  return f;
}

const std::string kKey = "team key";

TEST(FrameCodec, RoundTripsWhateverPiecesTheStreamArrivesIn) {
  std::vector<Frame> frames = {sampleFrame(0, 1), sampleFrame(1, 2), sampleFrame(5000, 3)};
  frames[1].type = FrameType::kAck;
  std::vector<std::uint8_t> stream;
  for (const auto& f : frames) {
    const auto bytes = encodeFrame(f, kKey);
    EXPECT_EQ(bytes.size(), wireBytes(f.payload.size()));
    stream.insert(stream.end(), bytes.begin(), bytes.end());
  }
  std::mt19937 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    FrameDecoder decoder(kKey, 10000);
    std::vector<Frame> decoded;
    std::size_t at = 0;
    while (at < stream.size()) {
      const std::size_t piece = std::min<std::size_t>(stream.size() - at, 1 + rng() % 700);
      decoder.feed(stream.data() + at, piece);
      at += piece;
      while (auto f = decoder.next()) decoded.push_back(*f);
    }
    ASSERT_EQ(decoder.error(), FrameError::kNone);
    ASSERT_EQ(decoded.size(), frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(decoded[i] == frames[i]);
    EXPECT_EQ(decoder.buffered(), 0U);
  }
}

FrameError decodeError(const std::vector<std::uint8_t>& bytes, const std::string& key = kKey,
                       std::size_t max_payload = 10000) {
  FrameDecoder decoder(key, max_payload);
  decoder.feed(bytes.data(), bytes.size());
  while (decoder.next()) {
  }
  return decoder.error();
}

TEST(FrameCodec, RefusesEachKindOfBadFrameByReason) {
  const auto good = encodeFrame(sampleFrame(100), kKey);
  EXPECT_EQ(decodeError(good), FrameError::kNone);
  EXPECT_EQ(decodeError(good, "another key"), FrameError::kBadMac) << "a peer without the key";
  auto bytes = good;
  bytes[0] = 'X';
  EXPECT_EQ(decodeError(bytes), FrameError::kBadMagic);
  bytes = good;
  bytes[4] = 9;
  EXPECT_EQ(decodeError(bytes), FrameError::kBadVersion);
  bytes = good;
  bytes[5] = 77;
  EXPECT_EQ(decodeError(bytes), FrameError::kUnknownType);
  EXPECT_EQ(decodeError(good, kKey, 99), FrameError::kTooLarge) << "judged on the header alone";
  bytes = good;
  bytes[10] = 5;  // fragment 5 of 1
  EXPECT_EQ(decodeError(bytes), FrameError::kBadFragment);
  bytes = good;
  bytes[kFrameHeaderBytes + 50] ^= 1;
  EXPECT_EQ(decodeError(bytes), FrameError::kBadMac) << "a flipped payload bit";
  // Truncated: no frame, no error yet (more bytes may come); the link's timeout ends it.
  bytes.assign(good.begin(), good.end() - 1);
  FrameDecoder decoder(kKey, 10000);
  decoder.feed(bytes.data(), bytes.size());
  EXPECT_FALSE(decoder.next());
  EXPECT_EQ(decoder.error(), FrameError::kNone);
  // After an error the stream stays failed, even if good frames follow.
  FrameDecoder failed(kKey, 10000);
  auto bad = good;
  bad[0] = 'X';
  failed.feed(bad.data(), bad.size());
  failed.feed(good.data(), good.size());
  EXPECT_FALSE(failed.next());
  EXPECT_FALSE(failed.next());
  EXPECT_EQ(failed.error(), FrameError::kBadMagic);
  Frame invalid = sampleFrame(1);
  invalid.fragment = 1;
  EXPECT_THROW(encodeFrame(invalid, kKey), std::invalid_argument);
}

TEST(FrameCodec, FuzzedInputNeverCrashesNorForgesAFrame) {
  std::mt19937 rng(3);
  const auto good = encodeFrame(sampleFrame(300), kKey);
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<std::uint8_t> bytes;
    if (trial % 2 == 0) {
      // Random bytes, sometimes behind a valid magic and version.
      bytes.resize(rng() % 2000);
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
      if (trial % 4 == 0 && bytes.size() > 6)
        std::copy(good.begin(), good.begin() + 6, bytes.begin());
    } else {
      // A valid frame with a few bytes changed, cut or extended.
      bytes = good;
      const int edits = 1 + static_cast<int>(rng() % 4);
      for (int e = 0; e < edits; ++e)
        bytes[rng() % bytes.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
      if (rng() % 3 == 0) bytes.resize(rng() % bytes.size());
    }
    FrameDecoder decoder(kKey, 1 << 20);
    decoder.feed(bytes.data(), bytes.size());
    while (auto f = decoder.next()) {
      // Only an unchanged frame may come out (a change that cancels itself is possible).
      EXPECT_TRUE(*f == sampleFrame(300)) << "trial " << trial;
    }
  }
}

TEST(MessageFragments, ReassembleInAnyOrderWithinBounds) {
  std::vector<std::uint8_t> message(200000);
  for (std::size_t i = 0; i < message.size(); ++i) message[i] = static_cast<std::uint8_t>(i * 7);
  auto frames = fragmentMessage(4, 99, message, 65536);
  ASSERT_EQ(frames.size(), 4U);
  for (const auto& f : frames) EXPECT_LE(f.payload.size(), 65536U);
  std::mt19937 rng(4);
  std::shuffle(frames.begin(), frames.end(), rng);
  Reassembler reassembler(1 << 20, 8);
  std::optional<std::vector<std::uint8_t>> out;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    out = reassembler.add(frames[i]);
    EXPECT_EQ(out.has_value(), i + 1 == frames.size());
    if (i == 0) {
      EXPECT_FALSE(reassembler.add(frames[0])) << "a repeated fragment is dropped";
    }
  }
  ASSERT_TRUE(out);
  EXPECT_EQ(*out, message);
  EXPECT_EQ(reassembler.droppedFragments(), 1U);
  EXPECT_EQ(reassembler.partialMessages(), 0U);

  // A small message is one frame; an empty one too.
  EXPECT_EQ(fragmentMessage(1, 1, std::vector<std::uint8_t>(10), 65536).size(), 1U);
  const auto empty = fragmentMessage(1, 2, {}, 65536);
  ASSERT_EQ(empty.size(), 1U);
  EXPECT_EQ(reassembler.add(empty[0])->size(), 0U);

  // Bounds: too big a message, and too many incomplete ones (the oldest goes).
  Reassembler small(100000, 2);
  for (const auto& f : fragmentMessage(5, 1, message, 65536)) EXPECT_FALSE(small.add(f));
  EXPECT_GT(small.droppedFragments(), 0U);
  Reassembler few(1 << 20, 2);
  for (std::uint64_t seq = 10; seq < 13; ++seq) few.add(fragmentMessage(6, seq, message, 65536)[0]);
  EXPECT_EQ(few.partialMessages(), 2U);
  EXPECT_EQ(few.droppedMessages(), 1U);
  // Incomplete messages hold at most twice the largest message together.
  Reassembler bounded(150000, 100);
  for (std::uint64_t seq = 20; seq < 30; ++seq) {
    const auto frames = fragmentMessage(7, seq, std::vector<std::uint8_t>(140000), 65536);
    bounded.add(frames[0]);
    bounded.add(frames[1]);
    EXPECT_LE(bounded.partialBytes(), 300000U);
  }
  EXPECT_GE(bounded.droppedMessages(), 7U);
  // Messages announcing 65 535 fragments of one byte each are bounded by their slots too.
  Reassembler slotted(150000, 64);
  for (std::uint64_t seq = 0; seq < 64; ++seq) {
    slotted.add({FrameType::kData, 0, 7, seq, 0, 65535, {1}});
    EXPECT_EQ(slotted.partialMessages(), 1U);
  }
  EXPECT_EQ(slotted.droppedMessages(), 63U);
  const auto whole = fragmentMessage(8, 1, std::vector<std::uint8_t>(140000), 65536);
  EXPECT_FALSE(slotted.add(whole[0]));
  EXPECT_FALSE(slotted.add(whole[1]));
  EXPECT_EQ(slotted.add(whole[2])->size(), 140000U) << "a real message still gets through";
  // A fragment that disagrees on the count is dropped.
  auto odd = fragmentMessage(6, 11, message, 65536)[1];
  odd.fragments = 9;
  EXPECT_FALSE(few.add(odd));
  EXPECT_THROW(fragmentMessage(1, 1, message, 0), std::invalid_argument);
}

constexpr std::uint16_t kScans = 1;
constexpr std::uint16_t kOffers = 2;
constexpr std::uint16_t kStats = 3;

LinkScheduler mineLink(double now = 0.0) {
  LinkScheduler link(150000.0, 131072, 65536, now);
  link.setTopic(kScans, {Priority::kBulk, QueuePolicy::kFifo, 0.0, 10});
  link.setTopic(kOffers, {Priority::kControl, QueuePolicy::kFifo, 0.0, 100});
  link.setTopic(kStats, {Priority::kControl, QueuePolicy::kKeepLatest, 0.0, 1});
  return link;
}

TEST(LinkScheduler, ControlOvertakesAScanBetweenItsFragments) {
  LinkScheduler link = mineLink();
  EXPECT_EQ(link.enqueue(kScans, std::vector<std::uint8_t>(200000, 1), 0.0), 1U);
  const auto first = link.next(0.0);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->topic, kScans);
  EXPECT_EQ(first->fragments, 4);
  EXPECT_EQ(link.queued(Priority::kBulk), 1U) << "a scan half sent is still queued";
  EXPECT_EQ(link.queuedBytes(Priority::kBulk), 200000U - first->payload.size());
  EXPECT_EQ(link.enqueue(kOffers, std::vector<std::uint8_t>(100, 2), 0.0), 1U);
  EXPECT_EQ(link.enqueue(kOffers, std::vector<std::uint8_t>(100, 3), 0.0), 2U);
  EXPECT_EQ(link.queuedBytes(Priority::kControl), 200U);
  // The bucket is short now: nothing until it refills, then the offers, then the scan goes on.
  std::vector<std::uint16_t> order;
  double t = 0.0;
  for (double wait = link.delay(t); !std::isinf(wait); wait = link.delay(t)) {
    t += wait;
    const auto f = link.next(t);
    ASSERT_TRUE(f) << "at " << t << " after " << order.size() << " frames, waited " << wait;
    order.push_back(f->topic);
  }
  EXPECT_EQ(order, (std::vector<std::uint16_t>{kOffers, kOffers, kScans, kScans, kScans}));
  EXPECT_EQ(link.counters().messages_sent, 3U);
  EXPECT_EQ(link.queuedBytes(Priority::kBulk) + link.queuedBytes(Priority::kControl), 0U);
}

TEST(LinkScheduler, SaturatedLinkStaysInBudgetAndControlStaysFast) {
  // Scans of ~120 KB every 0.5 s (twice what 150 KB/s carries) and an offer every 0.1 s, for 30 s.
  LinkScheduler link = mineLink();
  std::vector<std::pair<double, std::size_t>> sent;
  std::map<std::uint64_t, double> offer_enqueued;
  std::vector<double> offer_latency;
  double t = 0.0;
  double next_scan = 0.0;
  double next_offer = 0.0;
  while (t < 30.0) {
    if (t >= next_scan) {
      link.enqueue(kScans, std::vector<std::uint8_t>(120000), t);
      next_scan += 0.5;
    }
    if (t >= next_offer) {
      offer_enqueued[link.enqueue(kOffers, std::vector<std::uint8_t>(300), t)] = t;
      next_offer += 0.1;
    }
    while (auto f = link.next(t)) {
      sent.emplace_back(t, wireBytes(f->payload.size()));
      if (f->topic == kOffers) offer_latency.push_back(t - offer_enqueued.at(f->sequence));
    }
    t += 0.001;
  }
  // Every 1 s window: at most burst + rate; overall at least 90 % of the budget used.
  double total = 0;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    total += sent[i].second;
    double window = 0;
    for (std::size_t j = i; j < sent.size() && sent[j].first < sent[i].first + 1.0; ++j) {
      window += sent[j].second;
    }
    ASSERT_LE(window, 131072 + 150000.0) << "window from " << sent[i].first;
  }
  EXPECT_GT(total, 0.9 * 150000.0 * 30.0);
  // An offer waits at most for the fragment on the wire: 64 KB at 150 KB/s.
  ASSERT_GT(offer_latency.size(), 250U);
  std::sort(offer_latency.begin(), offer_latency.end());
  EXPECT_LT(offer_latency.back(), 65536.0 / 150000.0 + 0.01);
  EXPECT_GT(link.counters().dropped_queue_full, 0U) << "the scan queue overflowed, bounded";
  EXPECT_LE(link.queued(Priority::kBulk), 11U) << "max_queued waiting and one going";
}

TEST(LinkScheduler, LinksSharingATotalBudgetStayWithinItTogether) {
  // Two links of 150 KB/s each under a total of 100 KB/s, both saturated with scans for 20 s.
  auto total = std::make_shared<TokenBucket>(100000.0, 131072.0, 0.0);
  std::vector<LinkScheduler> links = {mineLink(), mineLink()};
  std::vector<std::pair<double, std::size_t>> sent;
  std::vector<std::size_t> per_link(2, 0);
  for (auto& link : links) link.shareBucket(total);
  EXPECT_DOUBLE_EQ(links[0].availableTokens(0.0), 131072.0) << "both buckets start full";
  // Turns of one frame per link, starting after the link that sent last, as the Bridge does.
  std::size_t turn = 0;
  for (int ms = 0; ms < 20000; ++ms) {
    const double t = ms / 1000.0;
    for (auto& link : links) {
      if (ms % 500 == 0) link.enqueue(kScans, std::vector<std::uint8_t>(100000, 1), t);
    }
    for (bool progress = true; progress;) {
      progress = false;
      for (std::size_t k = 0; k < links.size(); ++k) {
        const std::size_t i = (turn + k) % links.size();
        if (const auto frame = links[i].next(t)) {
          sent.emplace_back(t, wireBytes(frame->payload.size()));
          per_link[i] += wireBytes(frame->payload.size());
          progress = true;
          turn = i + 1;
        }
      }
    }
  }
  for (std::size_t i = 0; i < sent.size(); ++i) {
    std::size_t bytes = 0;
    for (std::size_t j = i; j < sent.size() && sent[j].first < sent[i].first + 1.0; ++j)
      bytes += sent[j].second;
    ASSERT_LE(bytes, 131072 + 100000) << "in the second from " << sent[i].first;
  }
  const double total_bytes = static_cast<double>(per_link[0] + per_link[1]);
  EXPECT_GT(total_bytes, 0.9 * 100000.0 * 20.0);
  EXPECT_LE(total_bytes, 131072 + 100000.0 * 20.0);
  EXPECT_GT(per_link[1], total_bytes / 4) << "one link starved the other";
  // Saturated: what either link may send at once is what the shared bucket has left.
  EXPECT_LT(links[0].availableTokens(20.0), 131072.0);
  EXPECT_DOUBLE_EQ(links[0].availableTokens(20.0), total->tokens(20.0));
}

TEST(LinkScheduler, QueuePoliciesKeepLatestBoundAndExpire) {
  LinkScheduler link(1000.0, 70000, 1000, 0.0);
  link.setTopic(kStats, {Priority::kControl, QueuePolicy::kKeepLatest, 0.0, 1});
  link.setTopic(kOffers, {Priority::kControl, QueuePolicy::kFifo, 0.0, 2});
  link.setTopic(kScans, {Priority::kBulk, QueuePolicy::kFifo, 1.0, 10});
  // Stop sending for a while: empty the bucket.
  link.enqueue(kScans, std::vector<std::uint8_t>(60000), 0.0);
  while (link.next(0.0)) {
  }
  link.enqueue(kStats, {1}, 0.0);
  link.enqueue(kStats, {2}, 0.0);
  link.enqueue(kOffers, {1}, 0.0);
  link.enqueue(kOffers, {2}, 0.0);
  link.enqueue(kOffers, {3}, 0.0);
  link.enqueue(kScans, {9}, 0.0);
  EXPECT_EQ(link.counters().replaced, 1U);
  EXPECT_EQ(link.counters().dropped_queue_full, 1U);
  // Much later: the scan is too old, the rest goes out in order.
  std::vector<std::vector<std::uint8_t>> out;
  double t = 100.0;
  while (!std::isinf(link.delay(t))) {
    t += link.delay(t);
    out.push_back(link.next(t)->payload);
  }
  EXPECT_EQ(out.size(), 3U);
  EXPECT_EQ(out[0], std::vector<std::uint8_t>{2}) << "the latest stats only";
  EXPECT_EQ(out[1], std::vector<std::uint8_t>{2}) << "offer 1 was dropped for offer 3";
  EXPECT_EQ(out[2], std::vector<std::uint8_t>{3});
  EXPECT_GE(link.counters().dropped_expired, 1U);
  EXPECT_THROW(link.enqueue(42, {}, t), std::invalid_argument);
  EXPECT_THROW(LinkScheduler(1000.0, 1000, 65536, 0.0), std::invalid_argument);
}

TEST(ReliableDelivery, EveryMessageArrivesExactlyOnceAcrossADisconnect) {
  ReliableOutbox outbox(1 << 20);
  SequenceFilter filter;
  std::vector<std::uint64_t> delivered;
  bool connected = true;
  std::uint64_t acknowledged = 0;
  auto wire = [&](std::uint64_t sequence) {
    // The link drops while messages 41 to 50 are on it; the acknowledgement of 40 is lost too.
    if (!connected) return;
    if (filter.accept("robot_b", 1, sequence)) delivered.push_back(sequence);
    const std::uint64_t have = filter.delivered("robot_b", 1);
    if (have % 10 == 0 && have != 40) acknowledged = have;
    outbox.acknowledge(1, acknowledged);
  };
  for (std::uint64_t seq = 1; seq <= 100; ++seq) {
    outbox.sent(1, seq, std::vector<std::uint8_t>(100, static_cast<std::uint8_t>(seq)));
    connected = seq <= 40 || seq > 50;
    if (seq == 51) {
      // Reconnected: first everything not acknowledged (31 .. 50, then 51 itself).
      for (const auto& m : outbox.unacknowledged()) wire(m.sequence);
      continue;
    }
    wire(seq);
  }
  std::vector<std::uint64_t> expected(100);
  std::iota(expected.begin(), expected.end(), 1);
  EXPECT_EQ(delivered, expected);
  EXPECT_EQ(filter.duplicates(), 10U) << "31 .. 40 came twice and were dropped once";
  EXPECT_EQ(filter.missing(), 0U);
  EXPECT_LT(outbox.messages(), 10U) << "acknowledged messages are released";

  // A bounded outbox gives the oldest up; the receiver sees the gap.
  ReliableOutbox small(1000);
  for (std::uint64_t seq = 1; seq <= 15; ++seq) small.sent(2, seq, std::vector<std::uint8_t>(100));
  EXPECT_EQ(small.givenUp(), 5U);
  EXPECT_EQ(small.unacknowledged().front().sequence, 6U);
  SequenceFilter gaps;
  EXPECT_TRUE(gaps.accept("robot_c", 2, 6));
  EXPECT_EQ(gaps.missing(), 5U);
  EXPECT_FALSE(gaps.accept("robot_c", 2, 6));
  EXPECT_TRUE(gaps.accept("robot_b", 2, 1)) << "per peer";
}

TEST(LinkEmulator, KeepsOrderRateDelayLossOutagesAndItsSeed) {
  LinkEmulatorParams params;
  params.rate_bytes_per_s = 100000.0;
  params.delay_s = 0.05;
  params.jitter_s = 0.02;
  params.loss = 0.1;
  params.outages = {{5.0, 7.0}};
  params.seed = 9;
  LinkEmulator link(params);
  std::vector<double> sent;
  std::vector<double> arrived;
  for (int i = 0; i < 2000; ++i) {
    const double t = 0.005 * i;  // 1000-byte chunks at 200 KB/s: twice the rate
    sent.push_back(t);
    arrived.push_back(link.arrival(1000, t));
  }
  EXPECT_TRUE(std::is_sorted(arrived.begin(), arrived.end())) << "a stream keeps its order";
  for (std::size_t i = 0; i < arrived.size(); ++i) {
    EXPECT_GE(arrived[i], sent[i] + params.delay_s - params.jitter_s - 1e-9);
    EXPECT_FALSE(link.down(arrived[i])) << "arrived during the outage";
  }
  // The rate: 2 MB took at least 20 s of link time plus the 2 s outage.
  EXPECT_GE(arrived.back(), 2000 * 1000 / params.rate_bytes_per_s + 2.0);
  EXPECT_LT(arrived.back(), 2000 * 1000 / params.rate_bytes_per_s + 2.0 + 0.5);
  // The same seed gives the same link.
  LinkEmulator again(params);
  for (std::size_t i = 0; i < sent.size(); ++i) ASSERT_EQ(again.arrival(1000, sent[i]), arrived[i]);
  // A lossless, jitter-free, idle link: exactly serialisation + delay.
  LinkEmulatorParams plain;
  plain.jitter_s = 0.0;
  plain.rate_bytes_per_s = 1000.0;
  EXPECT_DOUBLE_EQ(LinkEmulator(plain).arrival(500, 1.0), 1.0 + 0.5 + plain.delay_s);
  LinkEmulatorParams bad;
  bad.loss = 2.0;
  EXPECT_THROW(LinkEmulator{bad}, std::invalid_argument);
}

TEST(Compression, RoundTripsAndRefusesBombsAndGarbage) {
  // A scan-like message: floats with repeated structure.
  std::vector<std::uint8_t> message;
  for (int i = 0; i < 50000; ++i)
    message.push_back(static_cast<std::uint8_t>((i % 16) * (i / 4096)));
  const auto packed = compress(message);
  EXPECT_LT(packed.size(), message.size() / 4);
  const auto unpacked = decompress(packed, message.size());
  ASSERT_TRUE(unpacked);
  EXPECT_EQ(*unpacked, message);
  EXPECT_FALSE(decompress(packed, message.size() - 1)) << "states more than the bound";
  auto truncated = packed;
  truncated.pop_back();
  EXPECT_FALSE(decompress(truncated, message.size()));
  EXPECT_FALSE(decompress(std::vector<std::uint8_t>(100, 7), 1 << 20));
  EXPECT_FALSE(decompress({}, 1 << 20));
  const auto empty = decompress(compress({}), 10);
  ASSERT_TRUE(empty);
  EXPECT_TRUE(empty->empty());
}

using test::number;
using test::numbered;

/// Two sessions joined by a byte pipe each way; a direction that is down drops what is on it.
struct Pair {
  PeerSession a{"robot_a", "robot_b", kKey, SessionParams{}, 0.0};
  PeerSession b{"robot_b", "robot_a", kKey, SessionParams{}, 0.0};
  std::vector<InboxMessage> at_a;
  std::vector<InboxMessage> at_b;
  bool ok = true;

  void step(double t, bool a_to_b, bool b_to_a) {
    const auto ab = a.output(t);
    const auto ba = b.output(t);
    if (a_to_b) ok = ok && b.input(ab.data(), ab.size(), t, at_b);
    if (b_to_a) ok = ok && a.input(ba.data(), ba.size(), t, at_a);
  }
};

TopicInfo scanTopic() {
  TopicInfo t;
  t.name = "inbox/scans";
  t.type = "ccir_mapping/Keyframe";
  t.md5 = "0123456789abcdef0123456789abcdef";
  t.definition = "uint64 id\n";
  t.policy = {Priority::kBulk, QueuePolicy::kFifo, 0.0, 1000};
  return t;
}

TEST(PeerSession, ReliableTopicArrivesExactlyOnceInOrderAcrossAReconnect) {
  Pair link;
  link.b.addTopic(scanTopic(), 0.0);  // b announces one too; nothing is sent on it
  link.a.connected(0.0);
  link.b.connected(0.0);
  // a's topic appears once the link is up: it is announced before its first message.
  const std::uint16_t scans = link.a.addTopic(scanTopic(), 0.0);
  // A message every 50 ms for 3 s, then 3 s more (ms steps). From 1.0 s to 1.5 s only the
  // acknowledgements are lost; from 2.0 s to 2.3 s the link is down both ways (a message
  // half-sent). Both sides reconnect at 1.5 s and 2.3 s.
  for (int ms = 0; ms < 6000; ++ms) {
    const double t = ms / 1000.0;
    if (ms % 50 == 0 && ms < 3000) {
      link.a.send(scans, std::vector<std::uint8_t>(5000, static_cast<std::uint8_t>(ms / 50 + 1)),
                  t);
    }
    if (ms == 1500 || ms == 2300) {
      link.a.connected(t);
      link.b.connected(t);
    }
    const bool down = ms >= 2000 && ms < 2300;
    link.step(t, !down, !down && (ms < 1000 || ms >= 1500));
  }
  ASSERT_TRUE(link.ok) << link.a.reason() << link.b.reason();
  ASSERT_EQ(link.at_b.size(), 60U);
  for (std::size_t i = 0; i < link.at_b.size(); ++i) {
    EXPECT_EQ(link.at_b[i].bytes,
              std::vector<std::uint8_t>(5000, static_cast<std::uint8_t>(i + 1)));
    EXPECT_EQ(link.at_b[i].topic.name, "inbox/scans");
    EXPECT_EQ(link.at_b[i].topic.md5, scanTopic().md5);
  }
  // The 10 delivered while their acknowledgements were lost came again and were dropped.
  EXPECT_EQ(link.b.duplicatesDropped(), 10U);
  EXPECT_TRUE(link.at_a.empty());
}

TEST(PeerSession, RefusesAForeignKeyAnotherRobotAndDataBeforeHello) {
  PeerSession a("robot_a", "robot_b", kKey, SessionParams{}, 0.0);
  a.addTopic(scanTopic(), 0.0);
  a.connected(0.0);
  const auto bytes = a.output(0.0);
  std::vector<InboxMessage> inbox;
  PeerSession foreign("robot_b", "robot_a", "not the team key", SessionParams{}, 0.0);
  foreign.connected(0.0);
  EXPECT_FALSE(foreign.input(bytes.data(), bytes.size(), 0.0, inbox));
  EXPECT_EQ(foreign.reason(), "bad mac");
  PeerSession expects_c("robot_b", "robot_c", kKey, SessionParams{}, 0.0);
  expects_c.connected(0.0);
  EXPECT_FALSE(expects_c.input(bytes.data(), bytes.size(), 0.0, inbox));
  EXPECT_NE(expects_c.reason().find("robot_c"), std::string::npos) << expects_c.reason();
  Frame data = sampleFrame(10);
  const auto rogue = encodeFrame(data, kKey);
  PeerSession b("robot_b", "robot_a", kKey, SessionParams{}, 0.0);
  b.connected(0.0);
  EXPECT_FALSE(b.input(rogue.data(), rogue.size(), 0.0, inbox));
  EXPECT_NE(b.reason().find("HELLO"), std::string::npos);
  EXPECT_FALSE(b.input(bytes.data(), bytes.size(), 0.0, inbox)) << "stays refused";
  EXPECT_TRUE(inbox.empty());
  EXPECT_THROW(a.send(7, {}, 0.0), std::invalid_argument);
}

// A minute without a link at 20 messages a second: all 1200 wait in the outbox (not bounded by
// the topic's max_queued of 100) and arrive once and in order after the outage, behind no
// resend of what had arrived before it.
TEST(PeerSession, ALongOutageLosesNoReliableMessage) {
  Pair link;
  TopicInfo pings = scanTopic();
  pings.policy = {Priority::kControl, QueuePolicy::kFifo, 0.0, 100};
  const auto id = link.a.addTopic(pings, 0.0);
  link.a.connected(0.0);
  link.b.connected(0.0);
  std::uint32_t n = 0;
  const auto run = [&](int from_ms, int to_ms, bool up) {
    for (int ms = from_ms; ms < to_ms; ++ms) {
      if (ms % 50 == 0) link.a.send(id, numbered(200, n++), ms / 1000.0);
      if (up) link.step(ms / 1000.0, true, true);
    }
  };
  run(0, 5000, true);
  link.a.disconnected();
  link.b.disconnected();
  run(5000, 65000, false);
  // What waits for the link is reported as queued (LinkStats) though it is in the outbox.
  EXPECT_EQ(link.a.queued(Priority::kControl), 1200U);
  EXPECT_EQ(link.a.queuedBytes(Priority::kControl), 1200U * 200U);
  EXPECT_EQ(link.a.queued(Priority::kBulk), 0U);
  link.a.connected(65.0);
  link.b.connected(65.0);
  run(65000, 75000, true);
  ASSERT_TRUE(link.ok) << link.a.reason() << link.b.reason();
  ASSERT_EQ(link.at_b.size(), n);
  for (std::uint32_t i = 0; i < n; ++i) EXPECT_EQ(number(link.at_b[i].bytes), i);
  EXPECT_EQ(link.b.missing(), 0U);
  EXPECT_EQ(link.b.duplicatesDropped(), 0U);
  EXPECT_EQ(link.a.counters().dropped_queue_full, 0U);
}

// What a peer can make us hold in topic announcements is bounded: a thousand topics pass, a
// flood of them (or of huge definitions) is refused.
TEST(PeerSession, BoundsWhatThePeerAnnounces) {
  for (const auto& [topics, definition_bytes, refused] :
       {std::tuple<int, std::size_t, bool>{1000, 10, false}, {1025, 10, true}, {70, 60000, true}}) {
    Pair link;
    TopicInfo t = scanTopic();
    t.definition.assign(definition_bytes, 'x');
    for (int i = 0; i < topics; ++i) link.a.addTopic(t, 0.0);
    link.a.connected(0.0);
    link.b.connected(0.0);
    for (int step = 0; step < 500; ++step) link.step(step / 10.0, true, true);
    EXPECT_EQ(link.ok, !refused) << topics;
    EXPECT_EQ(link.b.reason().find("more topic announcements") == 0, refused) << link.b.reason();
  }
}

TEST(PeerSession, ARestartedPeerGetsLatchedStateAndItsSequencesAnew) {
  SessionParams params;
  Pair link;
  TopicInfo map = scanTopic();
  map.name = "inbox/map";
  map.latched = true;
  TopicInfo offers = scanTopic();
  offers.name = "inbox/offers";
  offers.reliable = false;
  offers.compressed = true;
  offers.latched = true;
  offers.policy.priority = Priority::kControl;
  const auto map_id = link.a.addTopic(map, 0.0);
  const auto offers_id = link.a.addTopic(offers, 0.0);
  // Sent before any connection: the reliable one waits in the outbox; the unreliable one is
  // not sent then, but as the latest of a latched topic it goes to the next peer to say HELLO.
  link.a.send(map_id, std::vector<std::uint8_t>(3000, 1), 0.0);
  link.a.send(offers_id, std::vector<std::uint8_t>(3000, 2), 0.0);
  EXPECT_EQ(link.a.sessionCounters().dropped_not_connected, 1U);
  link.a.connected(0.0);
  link.b.connected(0.0);
  for (int ms = 0; ms < 200; ++ms) link.step(ms / 1000.0, true, true);
  ASSERT_TRUE(link.ok);
  const auto first_bytes = [](const std::vector<InboxMessage>& inbox) {
    std::vector<int> firsts;
    for (const auto& m : inbox) firsts.push_back(m.bytes.empty() ? -1 : m.bytes[0]);
    return firsts;
  };
  EXPECT_EQ(first_bytes(link.at_b), (std::vector<int>{1, 2})) << "each latched message once";
  link.a.send(map_id, std::vector<std::uint8_t>(3000, 3), 0.2);
  link.a.send(offers_id, std::vector<std::uint8_t>(3000, 4), 0.2);
  for (int ms = 200; ms < 400; ++ms) link.step(ms / 1000.0, true, true);
  ASSERT_EQ(first_bytes(link.at_b), (std::vector<int>{1, 2, 4, 3})) << "control first";
  EXPECT_EQ(link.at_b[2].bytes, std::vector<std::uint8_t>(3000, 4)) << "decompressed";
  EXPECT_TRUE(link.at_b[2].topic.compressed);
  EXPECT_LT(link.a.counters().bytes_sent, 3 * 3000 + 2000) << "compressed on the wire";

  // b restarts (a new process, a new incarnation): it gets the latest map again; a's
  // sequences continue, b's start again and are not taken for duplicates.
  params.incarnation = 2;
  PeerSession restarted("robot_b", "robot_a", kKey, params, 0.4);
  restarted.addTopic(map, 0.4);
  const auto b_map = restarted.addTopic(map, 0.4);
  restarted.send(b_map, std::vector<std::uint8_t>(10, 9), 0.4);
  std::vector<InboxMessage> at_restarted;
  for (int run = 0; run < 2; ++run) {
    // The first run is b's first process again (same sequences); the second, the restart.
    PeerSession& b = run == 0 ? link.b : restarted;
    auto& inbox = run == 0 ? link.at_b : at_restarted;
    link.a.disconnected();
    link.a.connected(0.4);
    b.connected(0.4);
    for (int ms = 400; ms < 600; ++ms) {
      const double t = ms / 1000.0;
      const auto ab = link.a.output(t);
      const auto ba = b.output(t);
      ASSERT_TRUE(b.input(ab.data(), ab.size(), t, inbox)) << b.reason();
      ASSERT_TRUE(link.a.input(ba.data(), ba.size(), t, link.at_a)) << link.a.reason();
    }
  }
  // Reconnecting to the same process: only the unreliable latched offers again; the
  // restarted process gets the latest of both.
  EXPECT_EQ(first_bytes(link.at_b), (std::vector<int>{1, 2, 4, 3, 4}));
  EXPECT_EQ(first_bytes(at_restarted), (std::vector<int>{4, 3}));
  ASSERT_EQ(link.at_a.size(), 1U) << "the restarted b's first message is not a duplicate";
  EXPECT_EQ(link.at_a[0].bytes, std::vector<std::uint8_t>(10, 9));
  EXPECT_EQ(link.a.sessionCounters().peer_restarts, 1U) << "a reconnection is not a restart";
}

TEST(PeerSession, KeepAliveIsHeardAndOversizedMessagesAreNotSent) {
  SessionParams params;
  params.max_message_bytes = 1000;
  PeerSession a("robot_a", "robot_b", kKey, params, 0.0);
  PeerSession b("robot_b", "robot_a", kKey, params, 0.0);
  const auto scans = a.addTopic(scanTopic(), 0.0);
  a.connected(0.0);
  b.connected(0.0);
  a.send(scans, std::vector<std::uint8_t>(1001, 1), 0.0);
  EXPECT_EQ(a.sessionCounters().dropped_too_large, 1U);
  std::vector<InboxMessage> inbox;
  auto bytes = a.output(0.0);  // its HELLO, alone until b's has come
  EXPECT_EQ(bytes.size(), wireBytes(8 + kNonceBytes + 7));
  ASSERT_TRUE(b.input(bytes.data(), bytes.size(), 0.0, inbox));
  bytes = b.output(0.0);
  ASSERT_TRUE(a.input(bytes.data(), bytes.size(), 0.0, inbox));
  bytes = a.output(0.0);  // the topic announcement, under the connection's key
  ASSERT_TRUE(b.input(bytes.data(), bytes.size(), 0.0, inbox));
  EXPECT_EQ(b.sessionCounters().last_heard_s, 0.0);
  a.keepAlive(5.0);
  bytes = a.output(5.0);
  EXPECT_EQ(bytes.size(), wireBytes(10));
  ASSERT_TRUE(b.input(bytes.data(), bytes.size(), 5.0, inbox));
  EXPECT_EQ(b.sessionCounters().last_heard_s, 5.0);
  EXPECT_TRUE(inbox.empty());
  a.disconnected();
  a.keepAlive(6.0);
  EXPECT_TRUE(a.output(6.0).empty());
}

TEST(PeerSession, ARecordedConnectionReplayedLaterIsRefusedAndChangesNothing) {
  Pair link;
  const std::uint16_t scans = link.a.addTopic(scanTopic(), 0.0);
  link.a.connected(0.0);
  link.b.connected(0.0);
  // What an eavesdropper records of a's side of a connection: HELLO, announcement, a message.
  std::vector<std::uint8_t> recorded;
  link.a.send(scans, {1, 2, 3}, 0.0);
  for (double t = 0.0; t < 1.0; t += 0.01) {
    const auto ab = link.a.output(t);
    recorded.insert(recorded.end(), ab.begin(), ab.end());
    ASSERT_TRUE(link.b.input(ab.data(), ab.size(), t, link.at_b));
    const auto ba = link.b.output(t);
    ASSERT_TRUE(link.a.input(ba.data(), ba.size(), t, link.at_a));
  }
  ASSERT_EQ(link.at_b.size(), 1U);
  // Played to b on a new connection: the HELLO is the team's, the frames after it are not this
  // connection's.
  link.b.connected(2.0);
  std::vector<InboxMessage> replayed;
  EXPECT_FALSE(link.b.input(recorded.data(), recorded.size(), 2.0, replayed));
  EXPECT_EQ(link.b.reason(), "bad mac");
  EXPECT_TRUE(replayed.empty());
  // The honest a on the next connection: its next message arrives once, the old one not again.
  link.a.connected(3.0);
  link.b.connected(3.0);
  link.a.send(scans, {4}, 3.0);
  for (double t = 3.0; t < 4.0; t += 0.01) link.step(t, true, true);
  ASSERT_TRUE(link.ok);
  ASSERT_EQ(link.at_b.size(), 2U);
  EXPECT_EQ(link.at_b[1].bytes, std::vector<std::uint8_t>{4});
  // A second HELLO on a connection is refused too.
  const Frame hello{FrameType::kHello, 0, 0, 0, 0, 1, encodeHello({"robot_a", 1, {}})};
  const auto bytes = encodeFrame(hello, kKey);
  EXPECT_FALSE(link.b.input(bytes.data(), bytes.size(), 4.0, link.at_b));
}

TEST(InboxPublishers, ANewTopicHoldsItsFirstMessagesAndRefusesAnotherType) {
  using Message = std::shared_ptr<const std::string>;
  std::vector<std::pair<std::string, std::string>> published;
  struct Sink {
    std::string topic;
    std::vector<std::pair<std::string, std::string>>* out;
    void publish(const Message& message) const { out->emplace_back(topic, *message); }
  };
  std::vector<std::string> advertised;
  InboxPublishers<Message, Sink> inbox(
      [&](const std::string& topic, const Message& first, bool latched) {
        advertised.push_back(topic + " (" + *first + (latched ? ", latched)" : ")"));
        return Sink{topic, &published};
      },
      0.5);
  const auto msg = [](const char* text) { return std::make_shared<const std::string>(text); };
  EXPECT_TRUE(inbox.publish("inbox/offers", "md5a", false, msg("1"), 10.0));
  EXPECT_TRUE(inbox.publish("inbox/offers", "md5a", false, msg("2"), 10.2));
  EXPECT_TRUE(published.empty()) << "held while subscribers connect";
  EXPECT_FALSE(inbox.publish("inbox/offers", "md5b", false, msg("x"), 10.3)) << "another type";
  inbox.flush(10.4);
  EXPECT_TRUE(published.empty());
  inbox.flush(10.5);
  using Published = std::vector<std::pair<std::string, std::string>>;
  EXPECT_EQ(published, (Published{{"inbox/offers", "1"}, {"inbox/offers", "2"}}));
  EXPECT_TRUE(inbox.publish("inbox/offers", "md5a", false, msg("3"), 10.6));
  EXPECT_EQ(published.size(), 3U) << "once ready, at once";
  EXPECT_TRUE(inbox.publish("inbox/scans", "md5b", true, msg("s"), 10.6));
  EXPECT_EQ(published.size(), 3U) << "a new topic holds its own";
  EXPECT_EQ(advertised, (std::vector<std::string>{"inbox/offers (1)", "inbox/scans (s, latched)"}));
}

}  // namespace
}  // namespace ccir_mapping::core::transport
