// rtukit driver: a man in the middle of an RTU line, for testing what a
// master and a slave do when frames are lost, corrupted or late. The relay
// serves a pty the master opens as its port, opens the slave's port as a
// master would, and passes every frame across, except what its FaultPlan
// (fault_plan.hpp) says to drop, corrupt or hold back. It sees every frame,
// so its record (on_frame) is also the observer: when a request reached the
// slave, when its answer came back.
//
//   asio::io_context ctx;
//   auto relay = rtukit::FaultRelay::start(ctx, {.device = "/tmp/ttyChair", .link = "/tmp/ttyHost"});
//   (*relay)->add("drop request fc06 0x0063=0");   // from any thread
//   ctx.run();
//
// Frames are found by length prediction and CRC (core/rtu.hpp); bytes that
// make no valid frame are not passed on (a slave would drop them too). One
// request at a time, as on a line: a reply is matched to the last request
// passed to the slave. Single-threaded on the io_context, except add(),
// clear() and rules(), which are safe from any thread.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/base/status.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/driver/fault_plan.hpp"
#include "rtukit/io/asio_fwd.hpp"
#include "rtukit/io/port.hpp"

namespace rtukit {

struct FaultRelayOptions {
  std::string device;         ///< the slave's port, opened as a master opens it
  io::SerialSettings serial;  ///< its settings (a pty ignores them)
  std::string link;           ///< a symlink to the pty the master opens ("": /dev/pts/N only)
  FrameQuirks quirks{};       ///< frame forms to recognise (the Rehand's 2-byte FC03 count)
  /// The time rules and records are on; nullptr: the steady clock. Must
  /// outlive the relay.
  DriverClock* clock = nullptr;
};

class FaultRelay {
 public:
  /// One frame as it crossed (or did not).
  /// A record as one line: "TIME request|reply pass|drop|corrupt|delay|sent
  /// HEX  # RULE", TIME in ms on the relay's clock (the steady clock: the
  /// machine's CLOCK_MONOTONIC, which every process shares).
  struct Record;
  static std::string line_of(const Record& r);

  struct Record {
    Clock::time_point at;            ///< when it was decided (or, delayed, sent), on the relay's clock
    FaultRule::Way way;              ///< request (master to slave) or reply
    FaultPlan::Decision::Kind kind;  ///< pass, drop, corrupt, delay (sent later), or pass after a delay
    bool delayed_send = false;       ///< the moment a delayed frame went out
    std::vector<uint8_t> adu;
    std::string rule;  ///< the rule that decided ("" for pass)
  };

  /// Creates the pty, opens the device and starts relaying on `ctx`.
  /// `on_frame` (may be empty) is called on ctx's thread for each frame.
  /// Errors: io_error (the pty, the device), invalid_argument (a link in use).
  static Outcome<std::unique_ptr<FaultRelay>> start(asio::io_context& ctx, FaultRelayOptions options,
                                                    std::function<void(const Record&)> on_frame = {});
  ~FaultRelay();
  FaultRelay(const FaultRelay&) = delete;
  FaultRelay& operator=(const FaultRelay&) = delete;

  /// Adds a rule (parse_fault_rule's text), armed now. Thread-safe.
  Status add(const std::string& rule);
  /// Removes every rule. Thread-safe.
  void clear();
  /// The rules in force, as text. Thread-safe.
  std::vector<std::string> rules() const;
  /// One console line: a rule (added), `rules` (those in force), `clear`,
  /// `help`; returns the answer, ending in a newline. Thread-safe.
  std::string command(const std::string& line);
  /// What the master opens.
  std::string port() const;

  struct Impl;

 private:
  explicit FaultRelay(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rtukit
