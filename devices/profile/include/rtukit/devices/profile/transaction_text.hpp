// rtukit device profiles, host side: a sniffed transaction (driver/sniffer.hpp)
// in the words of the device it was sent to. What a unit's registers are is
// read from its profile's rows, so a listener names "speed = 80 %" where the
// wire says 0x0023 = 80; a unit with no profile is described in Modbus terms.
//
//   profile::UnitProfiles units{{21, &inverjet_profile}};
//   for (const SniffedTransaction& t : sniffer.take()) puts(transaction_text(t, units).c_str());
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>

#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/driver/sniffer.hpp"

namespace rtukit::profile {

/// Which profile speaks for which unit.
using UnitProfiles = std::map<uint8_t, const Profile*>;

/// Registers from `address` on by their rows: "speed = 80 %, run_time = 30:00",
/// an entry of a repeated block as "key[2] = ...". An address no row starts
/// at (or a value cut short) as "0x0040 = 7".
std::string named_values(const Profile& profile, Space space, uint16_t address,
                         std::span<const uint16_t> words);

/// One transaction in a line: the unit ("all" for a broadcast, right-aligned
/// in 3), what was asked and what came back:
///   " 21 read holding 0x0021 x2: speed = 80 %, run_time = 30:00"
///   " 21 write speed = 80 % -> exception 02 (illegal data address)"
///   "  5 read coil 0x0000 x3: 101", "all write 0x0000 = 1 (broadcast)",
///   "  7 read input 0x0000 x1 -> no response", "garbage (3 bytes: 01 02 03)".
/// The unit's profile names registers where `profiles` has one.
std::string transaction_text(const SniffedTransaction& t, const UnitProfiles& profiles);

}  // namespace rtukit::profile
