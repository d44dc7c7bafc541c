#include "bridge_pump.h"

#include <limits>

namespace ccir_mapping::core::transport {

namespace {

// A read waits until the peer may make this side read this much (a frame header and more).
constexpr double kMinReadBytes = 1500.0;
// With a clock of unknown speed (mission time), a sender with something queued looks at it this
// often (wall seconds; with nothing queued it waits for the next message), and the keep-alives
// (every peer_timeout_s / 3 of it) this often, which follows replays up to 10 x real time.
constexpr double kClockPollS = 0.01;
constexpr double kKeepAlivePollS = 0.1;

}  // namespace

BridgePump::BridgePump(BridgeContext& context, Close close)
    : context_(context),
      close_(std::move(close)),
      pump_timer_(context.io),
      keepalive_timer_(context.io) {}

bool BridgePump::input(BridgeLink& link, const std::uint8_t* data, std::size_t n,
                       std::vector<InboxMessage>& inbox) {
  const auto restarts = link.session.sessionCounters().peer_restarts;
  if (link.session.input(data, n, context_.now(), inbox)) {
    link.backoff_s = 0.0;  // an authenticated peer: the next dial starts quick again
    if (link.session.sessionCounters().peer_restarts > restarts) {
      // As rare as a link coming up, so logged as one (not throttled with the warnings).
      context_.log(false, link.config.name +
                              " restarted (a new incarnation): its sequences start again and "
                              "it gets the latched topics' latest");
    }
    return true;
  }
  close_(link, "refused its stream: " + link.session.reason(), link.session.reason());
  return false;
}

void BridgePump::read(BridgeLink& link) {
  const auto generation = link.generation;
  const double t = context_.now();
  const double allowed = link.read_bucket->tokens(t);
  if (allowed < kMinReadBytes) {  // TCP holds the peer back meanwhile
    link.read_timer->expires_after(BridgeContext::after(
        context_.clock ? kClockPollS : link.read_bucket->delayFor(kMinReadBytes, t)));
    link.read_timer->async_wait([this, &link, generation](const boost::system::error_code& ec) {
      if (ec) return;
      std::lock_guard<std::mutex> lock(context_.mutex);
      if (generation == link.generation) read(link);
    });
    return;
  }
  auto chunk = std::make_shared<std::vector<std::uint8_t>>(
      std::min(BridgeStage::kReadChunkBytes, static_cast<std::size_t>(allowed)));
  link.socket->async_read_some(
      asio::buffer(*chunk),
      [this, &link, chunk, generation](const boost::system::error_code& ec, std::size_t n) {
        std::vector<InboxMessage> inbox;
        {
          std::lock_guard<std::mutex> lock(context_.mutex);
          if (generation != link.generation) return;
          if (ec)
            return close_(link, ec == asio::error::eof ? "closed by the peer" : ec.message(), "");
          link.read_bucket->tryConsume(n, context_.now());  // n <= tokens, which only grow
          if (!input(link, chunk->data(), n, inbox)) return;
          read(link);
          pump();  // acknowledgements
        }
        for (auto& message : inbox) context_.on_message(link.config.name, std::move(message));
      });
}

void BridgePump::pump() {
  auto& links = context_.links;
  const double t = context_.now();
  std::vector<std::vector<std::uint8_t>> out(links.size());
  for (bool progress = true; progress;) {
    progress = false;
    for (std::size_t k = 0; k < links.size(); ++k) {
      const std::size_t i = (turn_ + k) % links.size();
      BridgeLink& link = *links[i];
      if (!link.socket || link.writing) continue;
      const auto frame = link.session.output(t, 1);
      if (frame.empty()) continue;
      out[i].insert(out[i].end(), frame.begin(), frame.end());
      progress = true;
      turn_ = i + 1;
    }
  }
  double wait = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < links.size(); ++i) {
    BridgeLink& link = *links[i];
    if (!out[i].empty())
      write(link, std::make_shared<std::vector<std::uint8_t>>(std::move(out[i])));
    if (link.socket && !link.writing) wait = std::min(wait, link.session.outputDelay(t));
  }
  if (context_.clock && wait > 0 && std::isfinite(wait)) wait = kClockPollS;
  if (std::isfinite(wait)) {
    pump_timer_.expires_after(BridgeContext::after(wait));
    pump_timer_.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      std::lock_guard<std::mutex> lock(context_.mutex);
      pump();
    });
  }
}

void BridgePump::write(BridgeLink& link, const std::shared_ptr<std::vector<std::uint8_t>>& bytes) {
  link.writing = true;
  const auto generation = link.generation;
  asio::async_write(
      *link.socket, asio::buffer(*bytes),
      [this, &link, bytes, generation](const boost::system::error_code& ec, std::size_t) {
        std::lock_guard<std::mutex> lock(context_.mutex);
        if (generation != link.generation) return;
        link.writing = false;
        if (ec) return close_(link, ec.message(), "");
        pump();
      });
}

void BridgePump::keepAlive() {
  const double period_s = context_.params.peer_timeout_s / 3.0;
  keepalive_timer_.expires_after(BridgeContext::after(context_.clock ? kKeepAlivePollS : period_s));
  keepalive_timer_.async_wait([this, period_s](const boost::system::error_code& ec) {
    if (ec) return;
    std::lock_guard<std::mutex> lock(context_.mutex);
    const double t = context_.now();
    if (context_.clock && t < next_keepalive_s_) return keepAlive();
    next_keepalive_s_ = t + period_s;
    for (auto& link : context_.links) {
      if (!link->socket) continue;
      const double heard =
          std::max(link->session.sessionCounters().last_heard_s, link->connected_at_s);
      if (t - heard > context_.params.peer_timeout_s) {
        close_(*link, "silent for " + std::to_string(t - heard) + " s", "silent");
      } else {
        link->session.keepAlive(t);
      }
    }
    pump();
    keepAlive();
  });
}

}  // namespace ccir_mapping::core::transport
