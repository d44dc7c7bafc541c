#include "ccir_mapping/core/transport/bridge.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>

#include <boost/asio.hpp>

#include "listen.h"

namespace ccir_mapping::core::transport {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Socket = std::shared_ptr<tcp::socket>;

// A connection that has not said who it is: at most this many at once, for this long, and its
// first frame (a HELLO) no larger than this.
constexpr std::size_t kMaxUnidentified = 16;
constexpr double kIdentifyTimeoutS = 5.0;
constexpr std::size_t kHelloMaxBytes = 1024;
constexpr std::size_t kReadChunkBytes = 65536;
// With a clock of unknown speed (mission time), a sender with something queued looks at it this
// often (wall seconds; with nothing queued it waits for the next message), and the keep-alives
// (every peer_timeout_s / 3 of it) this often, which follows replays up to 10 x real time (a
// look advances the bridge's time by at most kMaxClockStepS).
constexpr double kClockPollS = 0.01;
constexpr double kKeepAlivePollS = 0.1;
// ... and take a larger step of it as a jump (a replay starting or skipping), not as time.
constexpr double kMaxClockStepS = 1.0;

std::string endpointText(const tcp::socket& socket) {
  boost::system::error_code ec;
  const auto remote = socket.remote_endpoint(ec);
  return ec ? std::string("?") : remote.address().to_string() + ":" + std::to_string(remote.port());
}

std::uint64_t drawIncarnation() {
  std::random_device device;
  return (static_cast<std::uint64_t>(device()) << 32) ^ device() ^
         static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
}

}  // namespace

struct Bridge::Impl {
  struct Link {
    PeerConfig config;
    bool dials = false;
    PeerSession session;
    Socket socket;
    std::uint64_t generation = 0;  // which connection a handler belongs to
    bool writing = false;
    double backoff_s = 0.0;
    double connected_at_s = 0.0;
    std::string address;
    std::map<std::string, std::uint64_t> refused;
    std::unique_ptr<asio::steady_timer> dial_timer;
  };

  BridgeParams params;
  std::string own;
  InboxHandler on_message;
  LogHandler on_log;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  Clock clock;                   // empty: steady time since start
  mutable double last_s = 0;     // the bridge's time: never back, at most kMaxClockStepS a look
  mutable double clock_s = NAN;  // the clock's reading at the last look
  double next_keepalive_s = 0;

  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> work{io.get_executor()};
  tcp::acceptor acceptor{io};
  asio::steady_timer pump_timer{io};
  asio::steady_timer keepalive_timer{io};
  std::thread thread;

  std::mutex mutex;  // everything below (the thread and publish() / reports())
  std::vector<std::unique_ptr<Link>> links;
  std::size_t turn = 0;
  std::map<std::string, std::pair<TopicInfo, std::vector<std::uint16_t>>> topics;
  std::uint64_t type_changed = 0;
  std::map<std::string, std::uint64_t> refused_unidentified;
  std::size_t unidentified = 0;

  double now() const {
    if (!clock) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    // Mission time jumps when a replay starts or skips: the bridge's time does not, so a link
    // is not found silent and no budget accrues across the jump.
    const double reading = clock();
    if (std::isfinite(clock_s)) last_s += std::clamp(reading - clock_s, 0.0, kMaxClockStepS);
    clock_s = reading;
    return last_s;
  }
  static asio::steady_timer::duration after(double s) {
    return std::chrono::duration_cast<asio::steady_timer::duration>(
        std::chrono::duration<double>(std::max(0.0, s)));
  }
  void warn(const std::string& text) {
    if (on_log) on_log(true, text);
  }

  // --- connections (all on the thread, with the mutex held) ---

  void scheduleDial(Link& link) {
    link.backoff_s = link.backoff_s == 0.0 ? params.reconnect_min_s
                                           : std::min(params.reconnect_max_s, 2.0 * link.backoff_s);
    link.dial_timer->expires_after(after(link.backoff_s));
    link.dial_timer->async_wait([this, &link](const boost::system::error_code& ec) {
      if (ec) return;
      std::lock_guard<std::mutex> lock(mutex);
      dial(link);
    });
  }

  void dial(Link& link) {
    if (link.socket) return;
    auto socket = std::make_shared<tcp::socket>(io);
    auto resolver = std::make_shared<tcp::resolver>(io);
    resolver->async_resolve(
        link.config.host, std::to_string(link.config.port),
        [this, &link, socket, resolver](const boost::system::error_code& ec,
                                        tcp::resolver::results_type endpoints) {
          std::lock_guard<std::mutex> lock(mutex);
          if (ec) {
            warn("cannot resolve " + link.config.host + " for " + link.config.name + ": " +
                 ec.message());
            return scheduleDial(link);
          }
          asio::async_connect(
              *socket, endpoints,
              [this, &link, socket](const boost::system::error_code& ec, const tcp::endpoint&) {
                std::lock_guard<std::mutex> lock(mutex);
                if (ec) return scheduleDial(link);
                std::vector<InboxMessage> none;
                if (!link.socket) attach(link, socket, {}, none);
              });
        });
  }

  void accept() {
    auto socket = std::make_shared<tcp::socket>(io);
    acceptor.async_accept(*socket, [this, socket](const boost::system::error_code& ec) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        std::lock_guard<std::mutex> lock(mutex);
        if (unidentified >= kMaxUnidentified) {
          ++refused_unidentified["too_many_unidentified"];
          socket->close();
        } else {
          ++unidentified;
          identify(socket, std::make_shared<std::vector<std::uint8_t>>(),
                   std::make_shared<asio::steady_timer>(io, after(kIdentifyTimeoutS)), true);
        }
      }
      accept();
    });
  }

  // Reads an accepted connection until its first frame names a configured peer.
  void identify(const Socket& socket, const std::shared_ptr<std::vector<std::uint8_t>>& bytes,
                const std::shared_ptr<asio::steady_timer>& deadline, bool first) {
    if (first) {
      deadline->async_wait([socket](const boost::system::error_code& ec) {
        if (!ec) socket->close();  // said nothing in time
      });
    }
    auto chunk = std::make_shared<std::array<std::uint8_t, kHelloMaxBytes>>();
    socket->async_read_some(
        asio::buffer(*chunk),
        [this, socket, bytes, deadline, chunk](const boost::system::error_code& ec, std::size_t n) {
          std::vector<InboxMessage> inbox;  // what came with the HELLO, delivered unlocked
          std::string peer;
          {
            std::lock_guard<std::mutex> lock(mutex);
            const auto give_up = [&](const std::string& reason) {
              --unidentified;
              ++refused_unidentified[reason];
              warn("refused a connection from " + endpointText(*socket) + ": " + reason);
              deadline->cancel();
              socket->close();
            };
            if (ec) return give_up(ec == asio::error::operation_aborted ? "silent" : "closed");
            bytes->insert(bytes->end(), chunk->begin(), chunk->begin() + n);
            FrameDecoder decoder(params.team_key, kHelloMaxBytes);
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
            const auto link = std::find_if(links.begin(), links.end(), [&](const auto& l) {
              return l->config.name == hello->robot;
            });
            if (link == links.end()) return give_up("unknown robot " + hello->robot);
            --unidentified;
            deadline->cancel();
            peer = hello->robot;
            attach(**link, socket, *bytes, inbox);
          }
          for (auto& message : inbox) on_message(peer, std::move(message));
        });
  }

  void attach(Link& link, const Socket& socket, const std::vector<std::uint8_t>& first_bytes,
              std::vector<InboxMessage>& inbox) {
    if (link.socket) close(link, "replaced by a new connection");
    boost::system::error_code ignored;
    socket->set_option(tcp::no_delay(true), ignored);
    link.socket = socket;
    link.address = endpointText(*socket);
    ++link.generation;
    link.connected_at_s = now();
    link.session.connected(now());
    if (on_log) on_log(false, "link to " + link.config.name + " (" + link.address + ") up");
    if (!first_bytes.empty() && !input(link, first_bytes.data(), first_bytes.size(), inbox)) {
      return;
    }
    read(link);
    pump();
  }

  bool input(Link& link, const std::uint8_t* data, std::size_t n,
             std::vector<InboxMessage>& inbox) {
    if (link.session.input(data, n, now(), inbox)) {
      link.backoff_s = 0.0;  // an authenticated peer: the next dial starts quick again
      return true;
    }
    close(link, "refused its stream: " + link.session.reason(), link.session.reason());
    return false;
  }

  void read(Link& link) {
    auto chunk = std::make_shared<std::vector<std::uint8_t>>(kReadChunkBytes);
    const auto generation = link.generation;
    link.socket->async_read_some(
        asio::buffer(*chunk),
        [this, &link, chunk, generation](const boost::system::error_code& ec, std::size_t n) {
          std::vector<InboxMessage> inbox;
          {
            std::lock_guard<std::mutex> lock(mutex);
            if (generation != link.generation) return;
            if (ec)
              return close(link, ec == asio::error::eof ? "closed by the peer" : ec.message());
            if (!input(link, chunk->data(), n, inbox)) return;
            read(link);
            pump();  // acknowledgements
          }
          for (auto& message : inbox) on_message(link.config.name, std::move(message));
        });
  }

  void close(Link& link, const std::string& why, const std::string& drop_reason = "") {
    if (!drop_reason.empty()) ++link.refused["refused: " + drop_reason];
    if (drop_reason.empty() && link.socket && link.session.partialInputBytes() > 0) {
      ++link.refused["truncated"];  // the connection ended inside a frame
    }
    if (link.socket) {
      warn("link to " + link.config.name + " (" + link.address + ") closed: " + why);
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

  // --- sending ---

  void pump() {
    const double t = now();
    std::vector<std::vector<std::uint8_t>> out(links.size());
    for (bool progress = true; progress;) {
      progress = false;
      for (std::size_t k = 0; k < links.size(); ++k) {
        const std::size_t i = (turn + k) % links.size();
        Link& link = *links[i];
        if (!link.socket || link.writing) continue;
        const auto frame = link.session.output(t, 1);
        if (frame.empty()) continue;
        out[i].insert(out[i].end(), frame.begin(), frame.end());
        progress = true;
        turn = i + 1;
      }
    }
    double wait = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < links.size(); ++i) {
      Link& link = *links[i];
      if (!out[i].empty())
        write(link, std::make_shared<std::vector<std::uint8_t>>(std::move(out[i])));
      if (link.socket && !link.writing) wait = std::min(wait, link.session.outputDelay(t));
    }
    if (clock && wait > 0 && std::isfinite(wait)) wait = kClockPollS;
    if (std::isfinite(wait)) {
      pump_timer.expires_after(after(wait));
      pump_timer.async_wait([this](const boost::system::error_code& ec) {
        if (ec) return;
        std::lock_guard<std::mutex> lock(mutex);
        pump();
      });
    }
  }

  void write(Link& link, const std::shared_ptr<std::vector<std::uint8_t>>& bytes) {
    link.writing = true;
    const auto generation = link.generation;
    asio::async_write(
        *link.socket, asio::buffer(*bytes),
        [this, &link, bytes, generation](const boost::system::error_code& ec, std::size_t) {
          std::lock_guard<std::mutex> lock(mutex);
          if (generation != link.generation) return;
          link.writing = false;
          if (ec) return close(link, ec.message());
          pump();
        });
  }

  void keepAlive() {
    const double period_s = params.peer_timeout_s / 3.0;
    keepalive_timer.expires_after(after(clock ? kKeepAlivePollS : period_s));
    keepalive_timer.async_wait([this, period_s](const boost::system::error_code& ec) {
      if (ec) return;
      std::lock_guard<std::mutex> lock(mutex);
      const double t = now();
      if (clock && t < next_keepalive_s) return keepAlive();
      next_keepalive_s = t + period_s;
      for (auto& link : links) {
        if (!link->socket) continue;
        const double heard =
            std::max(link->session.sessionCounters().last_heard_s, link->connected_at_s);
        if (t - heard > params.peer_timeout_s) {
          close(*link, "silent for " + std::to_string(t - heard) + " s", "silent");
        } else {
          link->session.keepAlive(t);
        }
      }
      pump();
      keepAlive();
    });
  }
};

Bridge::Bridge(const BridgeParams& params, const std::string& own_robot, InboxHandler on_message,
               LogHandler on_log, Clock clock)
    : impl_(std::make_unique<Impl>()) {
  const auto errors = params.validate(own_robot);
  if (!errors.empty()) throw std::invalid_argument("Bridge: " + errors.front());
  Impl& m = *impl_;
  m.params = params;
  m.own = own_robot;
  m.on_message = std::move(on_message);
  m.on_log = std::move(on_log);
  m.clock = std::move(clock);
  const double t = m.now();
  SessionParams session;
  session.budget_bytes_per_s = params.budget_bytes_per_s;
  session.burst_bytes = static_cast<std::size_t>(params.burst_bytes);
  session.fragment_bytes = static_cast<std::size_t>(params.fragment_bytes);
  session.max_message_bytes = static_cast<std::size_t>(params.max_message_bytes);
  session.incarnation = drawIncarnation();
  const auto total = std::make_shared<TokenBucket>(params.total_budget_bytes_per_s,
                                                   static_cast<double>(params.burst_bytes), t);
  for (const PeerConfig& peer : params.peers) {
    auto link = std::unique_ptr<Impl::Link>(
        new Impl::Link{peer, params.listen_port == 0 || own_robot < peer.name,
                       PeerSession(own_robot, peer.name, params.team_key, session, t)});
    link->session.shareBucket(total);
    link->dial_timer = std::make_unique<asio::steady_timer>(m.io);
    m.links.push_back(std::move(link));
  }
}

Bridge::~Bridge() {
  Impl& m = *impl_;
  if (m.thread.joinable()) {
    m.io.stop();
    m.thread.join();
  }
}

void Bridge::start() {
  Impl& m = *impl_;
  if (m.params.listen_port != 0) {
    const auto ec =
        listen(m.acceptor, {tcp::v4(), static_cast<unsigned short>(m.params.listen_port)});
    if (ec) {
      throw std::runtime_error("cannot listen on listen_port " +
                               std::to_string(m.params.listen_port) + ": " + ec.message());
    }
    m.accept();
  }
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    for (auto& link : m.links) {
      if (link->dials) m.dial(*link);
    }
    m.keepAlive();
  }
  m.thread = std::thread([&m] { m.io.run(); });
}

bool Bridge::publish(const TopicInfo& topic, std::vector<std::uint8_t> message,
                     const std::string& only_peer) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const double t = m.now();
  auto known = m.topics.find(topic.name);
  if (known == m.topics.end()) {
    std::vector<std::uint16_t> ids;
    for (auto& link : m.links) ids.push_back(link->session.addTopic(topic, t));
    known = m.topics.emplace(topic.name, std::make_pair(topic, ids)).first;
  } else if (known->second.first.md5 != topic.md5) {
    ++m.type_changed;
    return false;
  }
  std::vector<std::size_t> to;
  for (std::size_t i = 0; i < m.links.size(); ++i) {
    if (only_peer.empty() || m.links[i]->config.name == only_peer) to.push_back(i);
  }
  for (std::size_t n = 0; n < to.size(); ++n) {
    // The last link takes the message itself, the others a copy.
    auto bytes = n + 1 == to.size() ? std::move(message) : message;
    m.links[to[n]]->session.send(known->second.second[to[n]], std::move(bytes), t);
  }
  asio::post(m.io, [&m] {
    std::lock_guard<std::mutex> lock(m.mutex);
    m.pump();
  });
  return true;
}

std::vector<LinkReport> Bridge::reports() {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const double t = m.now();
  std::vector<LinkReport> reports;
  for (const auto& link : m.links) {
    LinkReport r;
    r.peer = link->config.name;
    r.connected = static_cast<bool>(link->socket);
    r.address =
        r.connected ? link->address : link->config.host + ":" + std::to_string(link->config.port);
    r.sent = link->session.counters();
    r.received = link->session.sessionCounters();
    r.queued_control = link->session.queued(Priority::kControl);
    r.queued_bulk = link->session.queued(Priority::kBulk);
    r.queued_control_bytes = link->session.queuedBytes(Priority::kControl);
    r.queued_bulk_bytes = link->session.queuedBytes(Priority::kBulk);
    r.available_tokens_bytes = link->session.availableTokens(t);
    r.silent_s = r.received.last_heard_s < 0 ? -1.0 : t - r.received.last_heard_s;
    r.at_s = t;
    r.drops = link->refused;
    r.drops["queue_full"] = r.sent.dropped_queue_full;
    r.drops["too_old"] = r.sent.dropped_expired;
    r.drops["replaced"] = r.sent.replaced;
    r.drops["not_connected"] = r.received.dropped_not_connected;
    r.drops["too_large"] = r.received.dropped_too_large;
    r.drops["given_up"] = link->session.givenUp();
    r.drops["duplicate"] = link->session.duplicatesDropped();
    r.drops["missing"] = link->session.missing();
    r.drops["type_changed"] = m.type_changed;
    reports.push_back(std::move(r));
  }
  if (!m.refused_unidentified.empty()) {
    LinkReport r;
    for (const auto& [reason, count] : m.refused_unidentified)
      r.drops["refused: " + reason] = count;
    reports.push_back(std::move(r));
  }
  return reports;
}

}  // namespace ccir_mapping::core::transport
