#include "bridge_connections.h"

#include <algorithm>
#include <array>
#include <stdexcept>

#include "ccir_mapping/core/transport/listen.h"

namespace ccir_mapping::core::transport {

namespace {

// A connection that has not said who it is: at most this many at once, for this long, and its
// first frame (a HELLO) no larger than this.
constexpr std::size_t kMaxUnidentified = 16;
constexpr double kIdentifyTimeoutS = 5.0;
constexpr std::size_t kHelloMaxBytes = 1024;
// A new connection replaces a link's only once the link has been silent this fraction of
// peer_timeout_s: two keep-alives missed.
constexpr double kLinkSilentForReplacementFraction = 2.0 / 3.0;

std::string endpointText(const tcp::socket& socket) {
  boost::system::error_code ec;
  const auto remote = socket.remote_endpoint(ec);
  return ec ? std::string("?") : remote.address().to_string() + ":" + std::to_string(remote.port());
}

}  // namespace

BridgeConnections::BridgeConnections(BridgeContext& context, BridgePump& pump)
    : context_(context), pump_(pump), acceptor_(context.io) {}

void BridgeConnections::listen() {
  const int port = context_.params.listen_port;
  const std::string& address = context_.params.listen_address;  // validated
  if (const auto ec = transport::listen(
          acceptor_, {boost::asio::ip::make_address(address), static_cast<unsigned short>(port)})) {
    throw std::runtime_error("cannot listen on listen_address " + address + " listen_port " +
                             std::to_string(port) + ": " + ec.message());
  }
  accept();
}

void BridgeConnections::dialAll() {
  for (auto& link : context_.links) {
    if (link->dials) dial(*link);
  }
}

void BridgeConnections::scheduleDial(BridgeLink& link) {
  const BridgeParams& params = context_.params;
  link.backoff_s = link.backoff_s == 0.0 ? params.reconnect_min_s
                                         : std::min(params.reconnect_max_s, 2.0 * link.backoff_s);
  link.dial_timer->expires_after(BridgeContext::after(link.backoff_s));
  link.dial_timer->async_wait([this, &link](const boost::system::error_code& ec) {
    if (ec) return;
    std::lock_guard<std::mutex> lock(context_.mutex);
    dial(link);
  });
}

void BridgeConnections::dial(BridgeLink& link) {
  if (link.socket) return;
  auto socket = std::make_shared<tcp::socket>(context_.io);
  auto resolver = std::make_shared<tcp::resolver>(context_.io);
  resolver->async_resolve(
      link.config.host, std::to_string(link.config.port),
      [this, &link, socket, resolver](const boost::system::error_code& ec,
                                      tcp::resolver::results_type endpoints) {
        std::lock_guard<std::mutex> lock(context_.mutex);
        if (ec) {
          context_.log(true, "cannot resolve " + link.config.host + " for " + link.config.name +
                                 ": " + ec.message());
          return scheduleDial(link);
        }
        asio::async_connect(
            *socket, endpoints,
            [this, &link, socket](const boost::system::error_code& ec, const tcp::endpoint&) {
              std::lock_guard<std::mutex> lock(context_.mutex);
              if (ec) return scheduleDial(link);
              std::vector<InboxMessage> none;
              if (!link.socket) attach(link, socket, {}, none);
            });
      });
}

void BridgeConnections::accept() {
  auto socket = std::make_shared<tcp::socket>(context_.io);
  acceptor_.async_accept(*socket, [this, socket](const boost::system::error_code& ec) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) {
      std::lock_guard<std::mutex> lock(context_.mutex);
      if (unidentified_ >= kMaxUnidentified) {
        ++refused_unidentified_["too_many_unidentified"];
        socket->close();
      } else {
        ++unidentified_;
        identify(socket, std::make_shared<std::vector<std::uint8_t>>(),
                 std::make_shared<asio::steady_timer>(context_.io,
                                                      BridgeContext::after(kIdentifyTimeoutS)),
                 true);
      }
    }
    accept();
  });
}

void BridgeConnections::identify(const Socket& socket,
                                 const std::shared_ptr<std::vector<std::uint8_t>>& bytes,
                                 const std::shared_ptr<asio::steady_timer>& deadline, bool first) {
  if (first) {
    deadline->async_wait([socket](const boost::system::error_code& ec) {
      if (!ec) socket->close();  // said nothing in time
    });
  }
  auto chunk = std::make_shared<std::array<std::uint8_t, kHelloMaxBytes>>();
  socket->async_read_some(asio::buffer(*chunk), [this, socket, bytes, deadline, chunk](
                                                    const boost::system::error_code& ec,
                                                    std::size_t n) {
    std::vector<InboxMessage> inbox;  // what came with the HELLO, delivered unlocked
    std::string peer;
    {
      std::lock_guard<std::mutex> lock(context_.mutex);
      const auto give_up = [&](const std::string& reason) {
        --unidentified_;
        ++refused_unidentified_[reason];
        context_.log(true, "refused a connection from " + endpointText(*socket) + ": " + reason);
        deadline->cancel();
        socket->close();
      };
      if (ec) return give_up(ec == asio::error::operation_aborted ? "silent" : "closed");
      bytes->insert(bytes->end(), chunk->begin(), chunk->begin() + n);
      FrameDecoder decoder(context_.params.team_key, kHelloMaxBytes);
      decoder.feed(bytes->data(), bytes->size());
      const auto frame = decoder.next();
      if (decoder.error() != FrameError::kNone) return give_up(toString(decoder.error()));
      if (!frame) {
        if (bytes->size() > 2 * kHelloMaxBytes) return give_up("too large");
        return identify(socket, bytes, deadline, false);
      }
      const auto hello =
          frame->type == FrameType::kHello ? decodeHello(frame->payload) : std::nullopt;
      if (!hello) return give_up("no HELLO");
      const auto link = std::find_if(context_.links.begin(), context_.links.end(),
                                     [&](const auto& l) { return l->config.name == hello->robot; });
      if (link == context_.links.end()) return give_up("unknown robot " + hello->robot);
      // A HELLO proves only that someone once heard the team key (it may be a recording): it
      // does not end a link still heard from. A peer that restarted closed its side (or went
      // silent), so its next dial gets through.
      if ((*link)->socket &&
          context_.now() - std::max((*link)->session.sessionCounters().last_heard_s,
                                    (*link)->connected_at_s) <
              kLinkSilentForReplacementFraction * context_.params.peer_timeout_s) {
        return give_up("link already up");
      }
      --unidentified_;
      deadline->cancel();
      peer = hello->robot;
      attach(**link, socket, *bytes, inbox);
    }
    for (auto& message : inbox) context_.on_message(peer, std::move(message));
  });
}

void BridgeConnections::attach(BridgeLink& link, const Socket& socket,
                               const std::vector<std::uint8_t>& first_bytes,
                               std::vector<InboxMessage>& inbox) {
  if (link.socket) close(link, "replaced by a new connection", "");
  boost::system::error_code ignored;
  socket->set_option(tcp::no_delay(true), ignored);
  link.socket = socket;
  link.address = endpointText(*socket);
  ++link.generation;
  link.connected_at_s = context_.now();
  link.session.connected(context_.now());
  context_.log(false, "link to " + link.config.name + " (" + link.address + ") up");
  if (!first_bytes.empty() && !pump_.input(link, first_bytes.data(), first_bytes.size(), inbox)) {
    return;
  }
  pump_.read(link);
  pump_.pump();
}

void BridgeConnections::close(BridgeLink& link, const std::string& why,
                              const std::string& refusal) {
  if (!refusal.empty()) ++link.refused["refused: " + refusal];
  if (refusal.empty() && link.socket && link.session.partialInputBytes() > 0) {
    ++link.refused["truncated"];  // the connection ended inside a frame
  }
  if (link.socket) {
    context_.log(true, "link to " + link.config.name + " (" + link.address + ") closed: " + why);
    boost::system::error_code ignored;
    link.socket->shutdown(tcp::socket::shutdown_both, ignored);
    link.socket->close(ignored);
    link.socket.reset();
  }
  ++link.generation;
  link.writing = false;
  link.session.disconnected();
  if (link.dials) scheduleDial(link);
}

}  // namespace ccir_mapping::core::transport
