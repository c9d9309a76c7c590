// A tap server's clients are sniffers: they must never slow the bus that
// publishes, so every write is asynchronous and a client's backlog is
// bounded rather than waited for.
#include "rtukit/term/tap_server.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include "rtukit/io/asio.hpp"

namespace rtukit::term {

using Local = asio::local::stream_protocol;

namespace {

struct Client {
  explicit Client(Local::socket s) : socket(std::move(s)) {}
  Local::socket socket;
  std::string pending, in_flight;
  bool writing = false;
};

}  // namespace

struct TapServer::State {
  State(asio::io_context& ctx, std::string p, Header h)
      : acceptor(ctx), path(std::move(p)), header(std::move(h)) {}

  void accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, Local::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) {
        auto c = std::make_shared<Client>(std::move(socket));
        c->pending = header();
        clients.push_back(c);
        flush(c);
      }
      accept();
    });
  }

  // One write in flight per client; what is published meanwhile gathers in
  // `pending` and goes out as one write when the previous one completes.
  void flush(const std::shared_ptr<Client>& c) {
    if (c->writing || c->pending.empty() || !c->socket.is_open()) return;
    c->writing = true;
    c->in_flight.swap(c->pending);
    c->pending.clear();
    asio::async_write(c->socket, asio::buffer(c->in_flight),
                      [this, c](const boost::system::error_code& ec, size_t) {
                        c->writing = false;
                        c->in_flight.clear();
                        if (ec) {
                          boost::system::error_code ignored;
                          c->socket.close(ignored);
                          clients.erase(std::remove(clients.begin(), clients.end(), c), clients.end());
                          return;
                        }
                        flush(c);
                      });
  }

  Local::acceptor acceptor;
  std::string path;
  Header header;
  std::vector<std::shared_ptr<Client>> clients;
  bool listening = false;
};

TapServer::TapServer(asio::io_context& ctx, std::string path, Header header)
    : state_(std::make_unique<State>(ctx, std::move(path), std::move(header))) {}

TapServer::~TapServer() {
  if (state_->listening) ::unlink(state_->path.c_str());
}

Status TapServer::listen() {
  const std::string& path = state_->path;
  const std::string dir = path.substr(0, path.rfind('/'));
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
    const int e = errno;
    return Status(Error(Errc::io_error, e), "cannot make " + dir + ": " + std::strerror(e));
  }
  // The directory holds a socket others connect to: it must be ours alone,
  // not a symlink or a directory someone else made to catch our clients.
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::getuid())
    return Status(Errc::io_error, dir + " is not a directory of ours");
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) return Status(Errc::io_error, path + " exists and is not a socket");
    // A socket that answers belongs to a live server; one that does not was
    // left by a server that was killed, and is ours to replace.
    Local::socket probe(state_->acceptor.get_executor());
    boost::system::error_code ec;
    probe.connect(Local::endpoint(path), ec);
    if (!ec) return Status(Errc::invalid_argument, "a bus of that name is running (" + path + ")");
    ::unlink(path.c_str());
  }
  boost::system::error_code ec;
  state_->acceptor.open(Local(), ec);
  if (!ec) state_->acceptor.bind(Local::endpoint(path), ec);
  if (!ec) state_->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return Status(Error(Errc::io_error, ec.value()), path + ": " + ec.message());
  state_->listening = true;
  state_->accept();
  return {};
}

void TapServer::publish(const std::string& line) {
  std::vector<std::shared_ptr<Client>>& clients = state_->clients;
  for (auto it = clients.begin(); it != clients.end();) {
    Client& c = **it;
    if (c.pending.size() + line.size() > kMaxBehind) {
      boost::system::error_code ignored;
      c.socket.close(ignored);
      it = clients.erase(it);
      continue;
    }
    c.pending += line;
    state_->flush(*it);
    ++it;
  }
}

}  // namespace rtukit::term
