// The sessions of the plain TCP listeners: the templates of sessions.hpp
// instantiated for one stream, in a file of their own so the two compile side by side.
#include "sessions.hpp"

namespace rtukit::web::detail {

void serve_plain(Server::Impl& server, size_t listener, Slot slot, const asio::ip::address& source,
                 std::string peer, tcp::socket socket) {
  std::make_shared<HttpSession<PlainStream>>(server, listener, std::move(slot), source, std::move(peer),
                                             PlainStream(std::move(socket)))
      ->start();
}

}  // namespace rtukit::web::detail
