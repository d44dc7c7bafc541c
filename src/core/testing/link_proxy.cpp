#include "ccir_mapping/core/testing/link_proxy.h"

#include <chrono>
#include <deque>
#include <future>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <boost/asio.hpp>

#include "ccir_mapping/core/transport/listen.h"

namespace ccir_mapping::core::testing {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

// A direction stops reading while this much waits to be delivered (TCP's back-pressure).
constexpr std::size_t kMaxBufferedBytes = 1 << 20;

}  // namespace

int freeLoopbackPort() {
  asio::io_context io;
  tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  return acceptor.local_endpoint().port();
}

struct LinkProxy::Impl {
  struct Connection;

  // One direction of one connection: read, hold each chunk until the emulated link delivers it,
  // write it on.
  struct Pipe {
    std::shared_ptr<tcp::socket> from;
    std::shared_ptr<tcp::socket> to;
    LinkEmulator link;
    bool towards_target = true;
    std::deque<std::pair<double, std::vector<std::uint8_t>>> queue;
    std::size_t queued_bytes = 0;
    bool reading = false;
    bool writing = false;
    std::unique_ptr<asio::steady_timer> timer;
  };

  struct Connection : std::enable_shared_from_this<Connection> {
    Impl* proxy = nullptr;
    std::unique_ptr<Pipe> up;    // client -> target
    std::unique_ptr<Pipe> down;  // target -> client
    bool closed = false;

    void close() {
      if (closed) return;
      closed = true;
      boost::system::error_code ignored;
      for (Pipe* p : {up.get(), down.get()}) {
        p->from->close(ignored);
        p->timer->cancel();
      }
    }

    void read(Pipe& pipe) {
      if (closed || pipe.reading || pipe.queued_bytes > kMaxBufferedBytes) return;
      pipe.reading = true;
      auto chunk = std::make_shared<std::vector<std::uint8_t>>(65536);
      auto self = shared_from_this();
      pipe.from->async_read_some(
          asio::buffer(*chunk),
          [self, &pipe, chunk](const boost::system::error_code& ec, std::size_t n) {
            pipe.reading = false;
            if (ec || self->closed) return self->close();
            chunk->resize(n);
            const double t = self->proxy->now();
            {
              std::lock_guard<std::mutex> lock(self->proxy->mutex);
              self->proxy->forwarded[pipe.towards_target].emplace_back(t, n);
            }
            pipe.queue.emplace_back(pipe.link.arrival(n, t), std::move(*chunk));
            pipe.queued_bytes += n;
            self->write(pipe);
            self->read(pipe);
          });
    }

    void write(Pipe& pipe) {
      if (closed || pipe.writing || pipe.queue.empty()) return;
      pipe.writing = true;
      auto self = shared_from_this();
      pipe.timer->expires_after(std::chrono::duration_cast<asio::steady_timer::duration>(
          std::chrono::duration<double>(std::max(0.0, pipe.queue.front().first - proxy->now()))));
      pipe.timer->async_wait([self, &pipe](const boost::system::error_code& ec) {
        if (ec || self->closed) return self->close();
        asio::async_write(*pipe.to, asio::buffer(pipe.queue.front().second),
                          [self, &pipe](const boost::system::error_code& ec, std::size_t) {
                            pipe.writing = false;
                            if (ec || self->closed) return self->close();
                            pipe.queued_bytes -= pipe.queue.front().second.size();
                            pipe.queue.pop_front();
                            self->write(pipe);
                            self->read(pipe);
                          });
      });
    }
  };

  LinkProxyParams params;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  asio::io_context io;
  tcp::acceptor acceptor{io};
  std::thread thread;
  std::vector<std::weak_ptr<Connection>> connections;  // on the thread only
  std::uint64_t seed;

  mutable std::mutex mutex;
  std::vector<std::pair<double, std::size_t>> forwarded[2];  // back, towards the target
  std::size_t accepted = 0;

  double now() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  std::unique_ptr<Pipe> pipe(std::shared_ptr<tcp::socket> from, std::shared_ptr<tcp::socket> to,
                             std::uint64_t pipe_seed, bool towards_target) {
    LinkEmulatorParams link = params.link;
    link.seed = pipe_seed;
    auto p = std::unique_ptr<Pipe>(new Pipe{std::move(from), std::move(to), LinkEmulator(link)});
    p->towards_target = towards_target;
    p->timer = std::make_unique<asio::steady_timer>(io);
    return p;
  }

  void accept() {
    auto client = std::make_shared<tcp::socket>(io);
    acceptor.async_accept(*client, [this, client](const boost::system::error_code& ec) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) relay(client);
      accept();
    });
  }

  void relay(const std::shared_ptr<tcp::socket>& client) {
    auto target = std::make_shared<tcp::socket>(io);
    const tcp::endpoint endpoint(asio::ip::make_address(params.target_host),
                                 static_cast<unsigned short>(params.target_port));
    target->async_connect(endpoint, [this, client, target](const boost::system::error_code& ec) {
      if (ec) return;  // the client sees its connection close
      auto c = std::make_shared<Connection>();
      c->proxy = this;
      c->up = pipe(client, target, seed, true);
      c->down = pipe(target, client, seed + 1, false);
      seed += 2;
      connections.push_back(c);
      {
        std::lock_guard<std::mutex> lock(mutex);
        ++accepted;
      }
      c->read(*c->up);
      c->read(*c->down);
    });
  }
};

LinkProxy::LinkProxy(const LinkProxyParams& params) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  LinkEmulator check(params.link);  // throws for a bad link
  if (params.target_port <= 0 || params.target_port > 65535) {
    throw std::invalid_argument("LinkProxy: target_port must be in [1, 65535]");
  }
  m.params = params;
  m.seed = params.link.seed;
  const auto ec = transport::listen(m.acceptor, {asio::ip::make_address("127.0.0.1"),
                                                 static_cast<unsigned short>(params.listen_port)});
  if (ec) {
    throw std::runtime_error("LinkProxy: cannot listen on port " +
                             std::to_string(params.listen_port) + ": " + ec.message());
  }
  m.accept();
  m.thread = std::thread([&m] { m.io.run(); });
}

LinkProxy::~LinkProxy() {
  impl_->io.stop();
  impl_->thread.join();
}

int LinkProxy::port() const { return impl_->acceptor.local_endpoint().port(); }

void LinkProxy::cut() {
  Impl& m = *impl_;
  std::promise<void> done;
  asio::post(m.io, [&m, &done] {
    for (auto& weak : m.connections) {
      if (auto c = weak.lock()) c->close();
    }
    m.connections.clear();
    done.set_value();
  });
  done.get_future().wait();
}

std::vector<std::pair<double, std::size_t>> LinkProxy::forwarded(bool towards_target) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->forwarded[towards_target];
}

std::size_t LinkProxy::connections() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->accepted;
}

}  // namespace ccir_mapping::core::testing
