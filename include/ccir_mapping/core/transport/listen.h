// Opening a listening TCP socket, shared by the bridge and the link proxy (core/testing).
#pragma once

#include <boost/asio.hpp>

namespace ccir_mapping::core::transport {

/// Opens, binds (address reuse on, so a restarted bridge need not wait out TIME_WAIT) and
/// listens; the first error, if any.
inline boost::system::error_code listen(boost::asio::ip::tcp::acceptor& acceptor,
                                        const boost::asio::ip::tcp::endpoint& endpoint) {
  boost::system::error_code ec;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(boost::asio::ip::tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(boost::asio::socket_base::max_listen_connections, ec);
  return ec;
}

}  // namespace ccir_mapping::core::transport
