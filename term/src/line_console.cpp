// A console session reads and answers asynchronously on the io_context's
// thread, so a slow or silent client never holds up the simulator it drives.
#include "rtukit/term/line_console.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include "rtukit/io/asio.hpp"

namespace rtukit::term {

using Local = asio::local::stream_protocol;

namespace {

struct Session : std::enable_shared_from_this<Session> {
  Session(Local::socket s, const ConsoleHandler* l) : socket(std::move(s)), on_line(l) {}
  void read() {
    auto self = shared_from_this();
    asio::async_read_until(socket, asio::dynamic_buffer(input, 4096), '\n',
                           [self](const boost::system::error_code& ec, size_t n) {
                             if (ec) return;
                             std::string line = self->input.substr(0, n - 1);
                             self->input.erase(0, n);
                             (*self->on_line)(line, [self](std::string text) {
                               auto out = std::make_shared<std::string>(std::move(text));
                               asio::async_write(self->socket, asio::buffer(*out),
                                                 [self, out](const boost::system::error_code&, size_t) {});
                             });
                             self->read();
                           });
  }
  Local::socket socket;
  const ConsoleHandler* on_line;  // the console's, which outlives every session's handler run
  std::string input;
};

}  // namespace

struct LineConsole::State {
  State(asio::io_context& ctx, std::string p, ConsoleHandler l)
      : acceptor(ctx), path(std::move(p)), on_line(std::move(l)) {}
  void accept() {
    acceptor.async_accept([this](const boost::system::error_code& ec, Local::socket s) {
      if (ec) return;
      std::make_shared<Session>(std::move(s), &on_line)->read();
      accept();
    });
  }
  Local::acceptor acceptor;
  std::string path;
  ConsoleHandler on_line;
};

Outcome<std::unique_ptr<LineConsole>> LineConsole::open(asio::io_context& ctx, const std::string& path,
                                                        ConsoleHandler on_line) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    // Only a socket may be replaced: the path may be a user's file, typed by mistake.
    if (!S_ISSOCK(st.st_mode))
      return Status(Errc::invalid_argument, path + " exists and is not a socket; not replacing it");
    ::unlink(path.c_str());  // a socket left by an earlier run
  }
  auto c =
      std::unique_ptr<LineConsole>(new LineConsole(std::make_unique<State>(ctx, path, std::move(on_line))));
  boost::system::error_code ec;
  Local::acceptor& acceptor = c->state_->acceptor;
  acceptor.open(Local(), ec);
  if (!ec) (void)acceptor.bind(Local::endpoint(path), ec);
  if (!ec) (void)acceptor.listen(8, ec);
  if (ec) return Status(Error(Errc::io_error, ec.value()), "console " + path + ": " + ec.message());
  ::chmod(path.c_str(), 0600);  // the console can inject faults: owner only
  c->state_->accept();
  return c;
}

LineConsole::LineConsole(std::unique_ptr<State> state) : state_(std::move(state)) {}

LineConsole::~LineConsole() {
  boost::system::error_code ec;
  state_->acceptor.close(ec);
  ::unlink(state_->path.c_str());
}

}  // namespace rtukit::term
