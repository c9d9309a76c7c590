// rtukit driver: a virtual multi-drop RS-485 bus on ptys. N pseudo-terminals
// joined as one half-duplex line (BusLine): every byte written on one port
// reaches all the others at the line's baud rate, with collisions and the
// configured faults. Simulators, our master and foreign tools (mbpoll,
// libmodbus, pymodbus) open the ports as if they were serial ports. A port
// nobody has open hears nothing (as an adapter that is not open), and what
// a client left unread when it closed the port is thrown away: the next
// client's first read is its own answer, never old traffic.
//
//   asio::io_context ctx;
//   auto bus = rtukit::VirtualBus::start(ctx, {.ports = 3, .links = {"/tmp/bus0", ...}, .line = {...}});
//   ctx.run();
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/driver/bus_line.hpp"
#include "rtukit/io/asio_fwd.hpp"

namespace rtukit {

struct VirtualBusOptions {
  unsigned ports = 2;
  /// Symlinks to the ports, in order (fewer than `ports`: the rest have only /dev/pts/N).
  std::vector<std::string> links;
  BusConfig line;
  /// Every character as it was on the line, once finished (a tap for a sniffer).
  std::function<void(const BusCharacter&)> tap;
  /// The bus's time base; nullptr: the steady clock. Must outlive the bus.
  DriverClock* clock = nullptr;
};

class VirtualBus {
 public:
  /// Creates the ptys and starts moving bytes on `ctx`. Errors: io_error
  /// (a pty or a link could not be made), invalid_argument (no ports).
  static Outcome<std::unique_ptr<VirtualBus>> start(asio::io_context& ctx, VirtualBusOptions options);
  ~VirtualBus();
  VirtualBus(const VirtualBus&) = delete;
  VirtualBus& operator=(const VirtualBus&) = delete;

  /// Changes the line's faults from now on (BusLine::set_faults): noise
  /// that stops, a cable pulled (drop_rate 1: nothing passes) and put back.
  /// Safe from any thread: the change is posted to the bus's io_context
  /// (a bus destroyed before it runs drops it). Destroy the bus on the
  /// context's thread, or after the context has stopped.
  void set_faults(const BusConfig& faults);

  /// What clients open: the link if one was given, else /dev/pts/N.
  std::vector<std::string> ports() const;
  BusLineStats stats() const;
  /// The bus's clock: microseconds since it started (the time base of the tap).
  uint64_t now_us() const;
  /// How many times a port's last client closed it with bytes unread, which
  /// were then thrown away. Safe from any thread.
  uint64_t unread_discarded() const;

  struct Impl;

 private:
  explicit VirtualBus(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit
