// The example third device: a room thermostat on Modbus-RTU. Its register
// table is data, the single source of truth for validation, decoding, state
// files, the CLI and the docs, like the built-in devices' tables.
// (docs/architecture.md, "A third device", walks through this folder.)
#pragma once

#include "rtukit/devices/profile/register_map.hpp"
#include "rtukit/devices/profile/schema.hpp"

namespace rtukit::thermostat {

using profile::Encoding;
using profile::Named;
using profile::Role;
using profile::Row;
using profile::Space;

inline constexpr Named kModes[] = {{0, "off"}, {1, "auto"}, {2, "boost"}};
inline constexpr Named kBaudRates[] = {{0, "9600"}, {1, "19200"}, {2, "38400"}};

inline constexpr Row kRows[] = {
    {.address = 0x0000,
     .key = "address",
     .title = "slave address",
     .range = {1, 247},
     .default_value = 7,
     .flags = profile::kPersisted | profile::kLinkAddress,
     .notes = "takes effect after the response"},
    {.address = 0x0001,
     .key = "baud",
     .title = "baud rate",
     .encoding = Encoding::choice,
     .range = {0, 2},
     .default_value = 1,
     .flags = profile::kPersisted | profile::kLinkBaud,
     .names = kBaudRates,
     .notes = "takes effect after the response"},
    {.address = 0x0002,
     .key = "mode",
     .title = "heating mode",
     .encoding = Encoding::choice,
     .range = {0, 2},
     .default_value = 1,
     .flags = profile::kPersisted,
     .names = kModes},
    {.address = 0x0003,
     .key = "setpoint",
     .title = "set temperature",
     .unit = "degC",
     .scale = 10,
     .range = {50, 300},
     .default_value = 210,
     .flags = profile::kPersisted},
    {.space = Space::input,
     .address = 0x0000,
     .key = "temperature",
     .title = "room temperature",
     .role = Role::status,
     .encoding = Encoding::i16,
     .unit = "degC",
     .scale = 10},
    {.space = Space::input,
     .address = 0x0001,
     .key = "heating",
     .title = "heater output",
     .role = Role::status,
     .unit = "%",
     .range = {0, 100}},
};

inline constexpr profile::Profile kProfile{
    .name = "thermostat",
    .title = "Room thermostat (the example third device)",
    .vendor = "rtukit example",
    .rows = kRows,
    .link = {.parity = 'E', .stop_bits = 1},  // address and baud: the link rows 0x0000, 0x0001
};

inline constexpr profile::RegisterMap kMap{kRows};

namespace reg {
inline constexpr profile::Handle mode = kMap.handle("mode");
inline constexpr profile::Handle setpoint = kMap.handle("setpoint");
inline constexpr profile::Handle temperature = kMap.handle("temperature");
inline constexpr profile::Handle heating = kMap.handle("heating");
}  // namespace reg

}  // namespace rtukit::thermostat
