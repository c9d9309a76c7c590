// The slave engine on arbitrary frames (RTU with a valid CRC appended, and
// MBAP). Properties: never crashes; a response is a valid frame for the same
// unit, either the request's function or its exception (fc | 0x80 with a
// code 01..04); a broadcast is never answered.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "rtukit/core.hpp"

namespace {

class Bank final : public rtukit::RegisterBank {
 public:
  // Every function, so that diagnostics, identification, FC16 and FC17 are fuzzed too.
  rtukit::FunctionSet functions() const noexcept override {
    return rtukit::kDataFunctions | rtukit::kRegisterCombinedFunctions | rtukit::kDiagnosticFunctions |
           rtukit::kIdentificationFunctions;
  }
  uint8_t exception_status() override { return 0x6D; }
  // Objects long enough that a stream needs "more follows".
  std::string_view device_object(uint8_t id) override {
    static const std::string long_text(120, 'x');
    if (id <= 2) return "basic";
    if (id == 0x05 || id == 0x80 || id == 0x81 || id == 0xFF) return long_text;
    return {};
  }
  std::array<uint16_t, 300> regs{};
  std::array<uint8_t, 300> bits{};
  rtukit::Errc read_holding_registers(uint16_t a, std::span<uint16_t> out) override {
    if (size_t{a} + out.size() > regs.size()) return rtukit::Errc::illegal_data_address;
    std::memcpy(out.data(), &regs[a], out.size() * 2);
    return rtukit::Errc::ok;
  }
  rtukit::Errc read_input_registers(uint16_t a, std::span<uint16_t> out) override {
    return read_holding_registers(a, out);
  }
  rtukit::Errc write_holding_registers(uint16_t a, std::span<const uint16_t> v) override {
    if (size_t{a} + v.size() > regs.size()) return rtukit::Errc::illegal_data_address;
    if (!v.empty() && v[0] == 0xDEAD) return rtukit::Errc::illegal_data_value;
    std::memcpy(&regs[a], v.data(), v.size() * 2);
    return rtukit::Errc::ok;
  }
  rtukit::Errc read_coils(uint16_t a, uint16_t n, std::span<uint8_t> out) override {
    if (size_t{a} + n > bits.size()) return rtukit::Errc::illegal_data_address;
    for (size_t i = 0; i < n; ++i) rtukit::set_bit(out, i, bits[a + i] != 0);
    return rtukit::Errc::ok;
  }
  rtukit::Errc write_coils(uint16_t a, uint16_t n, std::span<const uint8_t> packed) override {
    if (size_t{a} + n > bits.size()) return rtukit::Errc::illegal_data_address;
    for (size_t i = 0; i < n; ++i) bits[a + i] = rtukit::get_bit(packed, i);
    return rtukit::Errc::ok;
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace rtukit;
  if (size < 2 || size > kMaxPduSize + 1) return 0;
  static Bank bank;
  static SlaveEngine engine;
  static bool once = [] { return engine.add_unit(UnitId{1}, bank).ok(); }();
  (void)once;
  // Listen-only mode would silence every later input: leave it each time
  // (its own behaviour is tested in tests/core_slave_test.cpp).
  if (engine.listen_only()) {
    const uint8_t restart[] = {0x08, 0x00, 0x01, 0x00, 0x00};
    std::array<uint8_t, kMaxPduSize> scratch{};
    (void)engine.handle_pdu(UnitId{1}, restart, scratch);
  }

  // RTU: the input is address + PDU; append the CRC so the engine sees it.
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  const Result<size_t> n = rtu_encode(data[0] % 3, {data + 1, size - 1}, adu);
  if (!n.ok()) return 0;
  std::array<uint8_t, kMaxRtuAduSize> out{};
  const size_t m = engine.handle_rtu({adu.data(), *n}, out).length;
  if (m) {
    if (adu[0] == 0) std::abort();  // broadcast answered
    if (out[0] != adu[0] || !rtu_crc_ok({out.data(), m})) std::abort();
    if (out[1] != adu[1] && !(out[1] == (adu[1] | 0x80) && m == 5 && out[2] >= 1 && out[2] <= 4))
      std::abort();
  }

  // MBAP: header + the same PDU.
  std::array<uint8_t, kMaxMbapAduSize> tcp{};
  const Result<size_t> t = mbap_encode(0x1234, 1, {data + 1, size - 1}, tcp);
  if (!t.ok()) return 0;
  std::array<uint8_t, kMaxMbapAduSize> tout{};
  const size_t k = engine.handle_tcp({tcp.data(), *t}, tout).length;
  if (k && (k < 9 || tout[0] != 0x12 || tout[1] != 0x34 || *mbap_adu_size({tout.data(), k}) != k))
    std::abort();
  return 0;
}
