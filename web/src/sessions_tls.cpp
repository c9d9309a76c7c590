// The sessions of the TLS listeners: the templates of sessions.hpp
// instantiated for one stream, in a file of their own so the two compile side by side.
#include "sessions.hpp"

namespace rtukit::web::detail {

void serve_tls(Server::Impl& server, size_t listener, Slot slot, const asio::ip::address& source,
               std::string peer, tcp::socket socket, ssl::context& tls) {
  std::make_shared<HttpSession<TlsStream>>(server, listener, std::move(slot), source, std::move(peer),
                                           TlsStream(std::move(socket), tls))
      ->start();
}

}  // namespace rtukit::web::detail
