#include "rtukit/driver/virtual_bus.hpp"

#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <memory>

#include "rtukit/io/asio.hpp"
#include "rtukit/io/link.hpp"
#include "rtukit/io/pty.hpp"

namespace rtukit {

struct VirtualBus::Impl {
  // What a reader that stopped reading may have waiting; more is dropped (a
  // real line does not wait for a deaf listener either).
  static constexpr size_t kMaxPending = 64 * 1024;

  struct Port {
    Port(asio::io_context& ctx, io::Pty p, int fd) : pty(std::move(p)), stream(ctx, fd), retry(ctx) {}
    io::Pty pty;
    asio::posix::stream_descriptor stream;
    asio::steady_timer retry;
    std::array<uint8_t, 512> rx{};
    std::vector<uint8_t> pending, in_flight;
    bool writing = false;
    // Bytes went to the pty since it was last seen closed: a client may
    // have left some unread.
    bool unread = false;
  };

  Impl(asio::io_context& c, VirtualBusOptions o)
      : ctx(c),
        options(std::move(o)),
        line(options.ports, options.line),
        timer(c),
        clock(clock_or_steady(options.clock)),
        t0(clock.now()) {}

  uint64_t now() const {
    return static_cast<uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(clock.now() - t0).count());
  }

  // Every completion handler first asks whether the bus still exists: one
  // that Asio had already queued (its operation done, with success) when a
  // handler on the same context destroyed the bus still runs, and a cancel
  // in the destructor cannot reach it any more.
  std::shared_ptr<char> alive = std::make_shared<char>();

  void read(size_t i) {
    Port& p = *ports[i];
    p.stream.async_read_some(asio::buffer(p.rx), [this, i, life = std::weak_ptr<char>(alive)](
                                                     const boost::system::error_code& ec, size_t n) {
      if (life.expired() || ec == asio::error::operation_aborted) return;
      Port& port = *ports[i];
      if (ec) {
        // EIO: nobody has the port open. Look again a little later.
        hung_up(i);
        port.retry.expires_after(std::chrono::milliseconds(20));
        port.retry.async_wait(
            [this, i, life = std::weak_ptr<char>(alive)](const boost::system::error_code& e) {
              if (!life.expired() && !e) read(i);
            });
        return;
      }
      line.write(static_cast<unsigned>(i), std::span<const uint8_t>(port.rx.data(), n), now());
      schedule();
      read(i);
    });
  }

  void schedule() {
    const std::optional<uint64_t> due = line.next_due();
    if (!due) return;
    // A wait of the bus clock's duration: Asio's timer runs on the steady clock.
    const auto at = t0 + std::chrono::microseconds(*due);
    const auto from = clock.now();
    timer.expires_after(at > from ? at - from : Clock::duration::zero());
    timer.async_wait([this, life = std::weak_ptr<char>(alive)](const boost::system::error_code& ec) {
      if (!life.expired() && !ec) pump();
    });
  }

  void pump() {
    deliveries.clear();
    tapped.clear();
    line.advance(now(), deliveries, options.tap ? &tapped : nullptr);
    for (const BusCharacter& c : tapped) options.tap(c);
    // A port nobody has open hears nothing, as an adapter that is not open
    // does not: the kernel would keep the bytes for the next client, which
    // would read them before its first answer.
    open.assign(ports.size(), -1);
    for (const BusDelivery& d : deliveries) {
      Port& p = *ports[d.port];
      if (open[d.port] < 0) open[d.port] = p.pty.slave_open() ? 1 : 0;
      if (open[d.port] == 0) continue;
      if (p.pending.size() < kMaxPending) p.pending.push_back(d.byte);
    }
    for (size_t i = 0; i < ports.size(); ++i) flush(i);
    schedule();
  }

  void flush(size_t i) {
    Port& p = *ports[i];
    if (p.writing || p.pending.empty()) return;
    if (!p.pty.slave_open()) {
      hung_up(i);
      return;
    }
    p.writing = true;
    p.unread = true;
    p.in_flight.swap(p.pending);
    p.pending.clear();
    asio::async_write(
        p.stream, asio::buffer(p.in_flight),
        [this, i, life = std::weak_ptr<char>(alive)](const boost::system::error_code& ec, size_t) {
          if (life.expired() || ec == asio::error::operation_aborted) return;
          Port& port = *ports[i];
          port.writing = false;
          port.in_flight.clear();
          if (!port.pty.slave_open()) hung_up(i);  // closed while we wrote
          flush(i);
        });
  }

  // The last client closed the port: what it left unread goes (the next
  // client starts with an empty line, as with a real adapter).
  void hung_up(size_t i) {
    Port& p = *ports[i];
    p.pending.clear();
    if (!p.unread || p.writing) return;
    p.unread = false;
    if (!p.pty.discard_unread()) discarded.fetch_add(1, std::memory_order_relaxed);
  }

  asio::io_context& ctx;
  VirtualBusOptions options;
  BusLine line;
  asio::steady_timer timer;
  DriverClock& clock;
  Clock::time_point t0;
  std::vector<std::unique_ptr<Port>> ports;
  std::vector<BusDelivery> deliveries;
  std::vector<BusCharacter> tapped;
  std::vector<int> open;  // per port in one pump: -1 not asked yet, 0 closed, 1 open
  std::atomic<uint64_t> discarded{0};
};

VirtualBus::VirtualBus(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

VirtualBus::~VirtualBus() {
  impl_->timer.cancel();
  for (auto& p : impl_->ports) {
    boost::system::error_code ignored;
    p->stream.close(ignored);
    p->retry.cancel();
  }
}

Outcome<std::unique_ptr<VirtualBus>> VirtualBus::start(asio::io_context& ctx, VirtualBusOptions options) {
  if (options.ports == 0) return Status(Errc::invalid_argument, "a bus needs at least one port");
  auto impl = std::make_unique<Impl>(ctx, std::move(options));
  for (unsigned i = 0; i < impl->options.ports; ++i) {
    const std::string link = i < impl->options.links.size() ? impl->options.links[i] : std::string();
    Outcome<io::Pty> pty = io::Pty::create(link);
    if (!pty.ok()) return pty.error();
    // The bus does not hold its ports open: it must see whether a client does.
    pty->release_slave();
    const int fd = ::dup(pty->master_fd());
    if (fd < 0) return Status(Error(Errc::io_error, errno), std::string("dup: ") + std::strerror(errno));
    impl->ports.push_back(std::make_unique<Impl::Port>(ctx, std::move(*pty), fd));
  }
  for (size_t i = 0; i < impl->ports.size(); ++i) impl->read(i);
  return std::unique_ptr<VirtualBus>(new VirtualBus(std::move(impl)));
}

std::vector<std::string> VirtualBus::ports() const {
  std::vector<std::string> out;
  for (const auto& p : impl_->ports) out.push_back(p->pty.name());
  return out;
}

void VirtualBus::set_faults(const BusConfig& faults) {
  Impl* impl = impl_.get();
  asio::post(impl->ctx, [impl, faults, life = std::weak_ptr<char>(impl->alive)] {
    if (!life.expired()) impl->line.set_faults(faults);  // a bus destroyed meanwhile has no line
  });
}

BusLineStats VirtualBus::stats() const {
  return impl_->line.stats();
}

uint64_t VirtualBus::unread_discarded() const {
  return impl_->discarded.load(std::memory_order_relaxed);
}

uint64_t VirtualBus::now_us() const {
  return impl_->now();
}

}  // namespace rtukit
