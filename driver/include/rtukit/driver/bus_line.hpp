// rtukit driver: one half-duplex multi-drop RS-485 line, sans-IO. The
// virtual bus (virtual_bus.hpp) runs it over ptys; tests run it on virtual
// time.
//
// Every port is a UART on the line: what a port writes goes out one
// character at a time at the line's rate (start + data + parity + stop bits),
// after what that port queued before, and reaches every other port when its
// last bit has been sent. Two ports sending at once collide: every
// character whose time on the line overlaps another port's arrives
// corrupted, for every listener. Faults, each optional and drawn from a
// seeded generator (the same seed gives the same faults):
//   - bit errors (each data bit flipped with probability `bit_error_rate`),
//   - dropped characters (a framing error: nobody receives it),
//   - stray bytes in the silence after a transmission (noise between frames),
//   - delivery latency (a USB adapter's latency timer: received bytes reach
//     the reader only at multiples of `latency_us`),
//   - echo (the sender hears its own characters, as half-duplex adapters do;
//     every port, or only the ports in `echo_ports`).
//
//   rtukit::BusLine line(3, {.baud = 9600, .bits_per_char = 10});
//   line.write(0, request, now_us);
//   while (auto t = line.next_due()) { ... at *t: line.advance(*t, deliveries, &tap); }
#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <span>
#include <vector>

#include "rtukit/term/tap_client.hpp"

namespace rtukit {

struct BusConfig {
  uint32_t baud = 9600;
  /// Start + data + parity + stop bits: 10 for 8N1, 11 for 8E1 or 8N2.
  uint32_t bits_per_char = 10;
  double bit_error_rate = 0;  ///< per data bit, 0..1
  double drop_rate = 0;       ///< per character, 0..1
  double stray_rate = 0;      ///< per transmission end: a stray byte 5 characters later
  uint32_t latency_us = 0;    ///< deliveries rounded up to multiples of this (0: at once)
  bool echo = false;          ///< every sender receives its own characters too
  /// Only these ports (bit N: port N) hear their own characters: a master's
  /// half-duplex USB adapter echoes, a device's transceiver usually does not.
  uint32_t echo_ports = 0;
  uint64_t seed = 1;
};

/// A byte handed to a port's reader.
struct BusDelivery {
  unsigned port;
  uint8_t byte;
  uint64_t at_us;
};

/// A character as it was on the line (for a tap or a sniffer): the tap's
/// own record (io/tap_client.hpp), so a tap line is read back as one.
using BusCharacter = term::TapCharacter;

struct BusLineStats {
  uint64_t characters = 0;  ///< characters that went out (stray ones included)
  uint64_t collisions = 0;  ///< characters corrupted by another sender
  uint64_t bit_errors = 0;  ///< characters with at least one flipped bit
  uint64_t dropped = 0;
  uint64_t stray = 0;
  uint64_t busy_us = 0;  ///< time the line carried a character
};

class BusLine {
 public:
  /// `ports` >= 1. The config's rates are clamped to 0..1, baud >= 1.
  BusLine(unsigned ports, BusConfig config);

  /// Port `port` (< ports) wrote `bytes` at `now_us`. Times passed to write
  /// and advance must not go backwards.
  void write(unsigned port, std::span<const uint8_t> bytes, uint64_t now_us);
  /// When the next delivery or character end is due, or nothing pending.
  std::optional<uint64_t> next_due() const;
  /// Moves time to `now_us`: appends every delivery due to `out`, and every
  /// character that finished to `tap` (if given).
  void advance(uint64_t now_us, std::vector<BusDelivery>& out, std::vector<BusCharacter>* tap = nullptr);

  /// Changes the faults from now on, as a noise burst that ends or a cable
  /// pulled out and put back would: bit errors, drops, stray bytes, latency
  /// and echo are taken from `faults` (rates clamped to 0..1); the baud rate,
  /// the character size and the generator stay. A character finishing after
  /// this call gets the new faults; deliveries already scheduled keep their
  /// time.
  void set_faults(const BusConfig& faults);
  /// The configuration in effect (rates clamped).
  const BusConfig& config() const noexcept { return config_; }

  /// One character's time on the line, in nanoseconds.
  uint64_t char_ns() const noexcept { return char_ns_; }
  const BusLineStats& stats() const noexcept { return stats_; }
  unsigned ports() const noexcept { return static_cast<unsigned>(next_free_ns_.size()); }

 private:
  struct InAir {
    uint64_t start_ns, end_ns;
    int sender;
    uint8_t byte;
  };
  bool chance(double p);
  void finish(const InAir& c, std::vector<BusCharacter>* tap);

  BusConfig config_;
  uint64_t char_ns_;
  std::vector<uint64_t> next_free_ns_;  // per port: when its UART is free
  std::vector<InAir> in_air_;           // sorted by end time
  std::vector<InAir> recent_;           // finished, still able to overlap a later one
  std::vector<BusDelivery> outbox_;     // sorted by time
  std::mt19937_64 rng_;
  BusLineStats stats_;
};

}  // namespace rtukit
