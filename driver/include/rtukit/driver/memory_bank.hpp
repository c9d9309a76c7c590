// rtukit driver: a generic slave's memory. Four tables (coils, discrete
// inputs, holding and input registers) of the same size, starting at address
// 0. Reads or writes past the end answer exception 02; writes are all or
// nothing by construction (the range is checked before anything changes).
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rtukit/core/slave.hpp"

namespace rtukit {

class MemoryBank final : public RegisterBank {
 public:
  /// `size` entries per table (1..65536).
  explicit MemoryBank(size_t size = 10000)
      : holding(size, 0), input(size, 0), coils(size, 0), discrete(size, 0) {}

  /// The documented frame forms this slave accepts (`rtukit slave --quirk`).
  FrameQuirks accepted_quirks{};
  FrameQuirks quirks() const noexcept override { return accepted_quirks; }
  /// Every function rtukit implements: the data functions, mask write (16),
  /// read/write multiple (17), the serial line diagnostics and identification.
  FunctionSet functions() const noexcept override {
    return kDataFunctions | kRegisterCombinedFunctions | kDiagnosticFunctions | kIdentificationFunctions;
  }
  /// Identification objects (FC11, FC2B/0E) by id; 0, 1 and 2 must be present.
  std::map<uint8_t, std::string> objects{{0, "rtukit"}, {1, "rtukit-slave"}, {2, "1.0"}};
  std::string_view device_object(uint8_t id) override {
    const auto it = objects.find(id);
    return it == objects.end() ? std::string_view() : std::string_view(it->second);
  }

  std::vector<uint16_t> holding;
  std::vector<uint16_t> input;
  std::vector<uint8_t> coils;     ///< one element per coil, 0 or 1
  std::vector<uint8_t> discrete;  ///< one element per input, 0 or 1

  Errc read_coils(uint16_t address, uint16_t count, std::span<uint8_t> packed_out) override {
    return read_bits(coils, address, count, packed_out);
  }
  Errc read_discrete_inputs(uint16_t address, uint16_t count, std::span<uint8_t> packed_out) override {
    return read_bits(discrete, address, count, packed_out);
  }
  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    return read_regs(holding, address, out);
  }
  Errc read_input_registers(uint16_t address, std::span<uint16_t> out) override {
    return read_regs(input, address, out);
  }
  Errc write_coils(uint16_t address, uint16_t count, std::span<const uint8_t> packed) override {
    if (size_t{address} + count > coils.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < count; ++i) coils[address + i] = get_bit(packed, i) ? 1 : 0;
    return Errc::ok;
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    if (size_t{address} + values.size() > holding.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < values.size(); ++i) holding[address + i] = values[i];
    return Errc::ok;
  }

 private:
  static Errc read_bits(const std::vector<uint8_t>& table, uint16_t address, uint16_t count,
                        std::span<uint8_t> packed_out) {
    if (size_t{address} + count > table.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < count; ++i) set_bit(packed_out, i, table[address + i] != 0);
    return Errc::ok;
  }
  static Errc read_regs(const std::vector<uint16_t>& table, uint16_t address, std::span<uint16_t> out) {
    if (size_t{address} + out.size() > table.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < out.size(); ++i) out[i] = table[address + i];
    return Errc::ok;
  }
};

}  // namespace rtukit
