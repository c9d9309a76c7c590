// The relay (fault_relay.hpp): two byte streams, a framer on each, a FaultPlan
// between them. Everything runs on the io_context's thread; the plan is the
// one thing another thread touches (a test adding a rule), under a mutex.
#include "rtukit/driver/fault_relay.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <deque>
#include <mutex>

#include "rtukit/core/rtu.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/io/serial_config.hpp"

namespace rtukit {

struct FaultRelay::Impl {
  using Way = FaultRule::Way;
  using Kind = FaultPlan::Decision::Kind;

  struct Side {
    Side(asio::io_context& ctx, int fd, FrameShape shape) : stream(ctx, fd), framer(shape) {}
    asio::posix::stream_descriptor stream;
    RtuFramer framer;
    std::array<uint8_t, 512> rx{};
    std::deque<std::vector<uint8_t>> out;  ///< frames waiting to be written, in order
    bool writing = false;
  };
  struct Held {
    Clock::time_point at;
    Way way;
    std::vector<uint8_t> adu;
    std::string rule;
  };

  Impl(asio::io_context& c, FaultRelayOptions o, std::function<void(const Record&)> f)
      : ctx(c),
        options(std::move(o)),
        on_frame(std::move(f)),
        timer(c),
        clock(clock_or_steady(options.clock)) {}

  static uint64_t us(Clock::time_point t) {
    return static_cast<uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count());
  }

  void read(Side& s, Way from) {
    s.stream.async_read_some(
        asio::buffer(s.rx), [this, &s, from](const boost::system::error_code& ec, size_t n) {
          if (ec == asio::error::operation_aborted) return;
          if (ec) {
            // The master closed its port (EIO on the pty) or the device went
            // away: look again a little later, as a port that comes back.
            retry_read(s, from);
            return;
          }
          const auto now = clock.now();
          size_t fed = 0;
          while (fed < n) {
            fed += s.framer.feed(std::span<const uint8_t>(s.rx.data() + fed, n - fed), us(now));
            while (auto f = s.framer.next(us(now)))
              frame(from, std::vector<uint8_t>(f->adu.begin(), f->adu.end()), now);
          }
          read(s, from);
        });
  }

  void retry_read(Side& s, Way from) {
    auto t = std::make_shared<asio::steady_timer>(ctx, std::chrono::milliseconds(20));
    t->async_wait([this, t, &s, from](const boost::system::error_code& e) {
      if (!e) read(s, from);
    });
  }

  void frame(Way from, std::vector<uint8_t> adu, Clock::time_point now) {
    FaultPlan::Decision d;
    {
      std::lock_guard lock(mutex);
      d = plan.decide(
          from, adu, from == Way::reply ? std::span<const uint8_t>(last_request) : std::span<const uint8_t>(),
          now);
    }
    record(now, from, d.kind, adu, d.rule, false);
    switch (d.kind) {
      case Kind::drop:
        return;
      case Kind::corrupt:
        adu = FaultPlan::corrupted(adu);
        break;
      case Kind::delay:
        held.push_back(Held{now + d.delay, from, std::move(adu), d.rule});
        schedule();
        return;
      case Kind::pass:
        break;
    }
    send(from, std::move(adu));
  }

  void send(Way from, std::vector<uint8_t> adu) {
    if (from == Way::request) {
      // The reply that comes next answers this request.
      last_request = adu;
      device->framer.reset();
      if (adu.size() >= 6 && (adu[1] == 0x03 || adu[1] == 0x04))
        device->framer.expect_response(adu[1], static_cast<uint16_t>(adu[4] << 8 | adu[5]));
      else if (adu.size() >= 2)
        device->framer.expect_response(adu[1], 0);
    }
    Side& to = from == Way::request ? *device : *master;
    to.out.push_back(std::move(adu));
    flush(to);
  }

  void flush(Side& s) {
    if (s.writing || s.out.empty()) return;
    s.writing = true;
    asio::async_write(s.stream, asio::buffer(s.out.front()),
                      [this, &s](const boost::system::error_code& ec, size_t) {
                        if (ec == asio::error::operation_aborted) return;
                        s.writing = false;
                        s.out.pop_front();  // written, or the peer is gone: a line does not wait either
                        flush(s);
                      });
  }

  // Frames held back go out at their time, in the order they are due.
  void schedule() {
    if (held.empty()) return;
    auto first = held.begin();
    for (auto it = held.begin(); it != held.end(); ++it)
      if (it->at < first->at) first = it;
    // A wait of the relay clock's duration: Asio's timer runs on the steady clock.
    const auto from = clock.now();
    timer.expires_after(first->at > from ? first->at - from : Clock::duration::zero());
    timer.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;
      const auto now = clock.now();
      for (auto it = held.begin(); it != held.end();) {
        if (it->at > now) {
          ++it;
          continue;
        }
        Held h = std::move(*it);
        it = held.erase(it);
        record(now, h.way, Kind::delay, h.adu, h.rule, true);
        send(h.way, std::move(h.adu));
      }
      schedule();
    });
  }

  void record(Clock::time_point at, Way way, Kind kind, const std::vector<uint8_t>& adu,
              const std::string& rule, bool delayed_send) {
    if (on_frame) on_frame(Record{at, way, kind, delayed_send, adu, rule});
  }

  asio::io_context& ctx;
  FaultRelayOptions options;
  std::function<void(const Record&)> on_frame;
  asio::steady_timer timer;
  DriverClock& clock;
  io::Pty pty;
  std::unique_ptr<Side> master;  ///< the pty the master opened: requests come from it
  std::unique_ptr<Side> device;  ///< the slave's port: replies come from it
  std::vector<uint8_t> last_request;
  std::vector<Held> held;
  mutable std::mutex mutex;  ///< guards plan
  FaultPlan plan;
};

FaultRelay::FaultRelay(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

FaultRelay::~FaultRelay() {
  boost::system::error_code ignored;
  impl_->timer.cancel();
  impl_->master->stream.close(ignored);
  impl_->device->stream.close(ignored);
}

Outcome<std::unique_ptr<FaultRelay>> FaultRelay::start(asio::io_context& ctx, FaultRelayOptions options,
                                                       std::function<void(const Record&)> on_frame) {
  auto impl = std::make_unique<Impl>(ctx, std::move(options), std::move(on_frame));
  Result<int> device = io::open_serial_port(impl->options.device, impl->options.serial);
  if (!device.ok())
    return Status(device.error(),
                  fmt::format("{}: {}", impl->options.device,
                              device.error().os_error() ? std::strerror(device.error().os_error())
                                                        : std::string(device.error().name())));
  Outcome<io::Pty> pty = io::Pty::create(impl->options.link);
  if (!pty.ok()) {
    ::close(*device);
    return pty.error();
  }
  impl->pty = std::move(*pty);
  const int fd = ::dup(impl->pty.master_fd());
  if (fd < 0) {
    ::close(*device);
    return Status(Error(Errc::io_error, errno), std::string("dup: ") + std::strerror(errno));
  }
  impl->master = std::make_unique<Impl::Side>(ctx, fd, FrameShape::request);
  impl->device = std::make_unique<Impl::Side>(ctx, *device, FrameShape::response);
  impl->master->framer.set_quirks(impl->options.quirks);
  impl->device->framer.set_quirks(impl->options.quirks);
  impl->read(*impl->master, FaultRule::Way::request);
  impl->read(*impl->device, FaultRule::Way::reply);
  return std::unique_ptr<FaultRelay>(new FaultRelay(std::move(impl)));
}

Status FaultRelay::add(const std::string& text) {
  Outcome<FaultRule> rule = parse_fault_rule(text);
  if (!rule.ok()) return rule.error();
  std::lock_guard lock(impl_->mutex);
  impl_->plan.add(*rule, impl_->clock.now());
  return {};
}

void FaultRelay::clear() {
  std::lock_guard lock(impl_->mutex);
  impl_->plan.clear();
}

std::vector<std::string> FaultRelay::rules() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<std::string> out;
  for (const FaultRule& r : impl_->plan.rules(impl_->clock.now())) out.push_back(r.text());
  return out;
}

std::string FaultRelay::command(const std::string& line) {
  if (line == "help") return std::string(fault_rule_help()) + "other commands: rules, clear, help\n";
  if (line == "clear") {
    clear();
    return "rules cleared\n";
  }
  if (line == "rules") {
    std::string out;
    for (const std::string& r : rules()) out += r + "\n";
    return out.empty() ? "no rules\n" : out;
  }
  Outcome<FaultRule> rule = parse_fault_rule(line);
  if (!rule.ok()) return std::string(rule.error().reason()) + "\n";
  std::lock_guard lock(impl_->mutex);
  impl_->plan.add(*rule, impl_->clock.now());
  return fmt::format("added: {}\n", rule->text());
}

std::string FaultRelay::line_of(const Record& r) {
  using Kind = FaultPlan::Decision::Kind;
  const char* kind = r.delayed_send            ? "sent"
                     : r.kind == Kind::pass    ? "pass"
                     : r.kind == Kind::drop    ? "drop"
                     : r.kind == Kind::corrupt ? "corrupt"
                                               : "delay";
  std::string hex;
  for (uint8_t b : r.adu) hex += fmt::format("{:02X} ", b);
  if (!hex.empty()) hex.pop_back();
  return fmt::format("{:.3f} {} {} {}{}{}",
                     std::chrono::duration<double, std::milli>(r.at.time_since_epoch()).count(),
                     r.way == FaultRule::Way::request ? "request" : "reply", kind, hex,
                     r.rule.empty() ? "" : "  # ", r.rule);
}

std::string FaultRelay::port() const {
  return impl_->pty.name();
}

}  // namespace rtukit
