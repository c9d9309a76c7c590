// The core with every feature switch off (rtukit_core_minimal: RTUKIT_CORE_*=0,
// as the cortex-m4-minimal preset builds it): a slave for 03/04/06/10 that
// answers every other function with exception 01, wire bytes in, wire bytes out.
#include <gtest/gtest.h>

#include <string>

#include "rtukit/core.hpp"
#include "wire.hpp"

using namespace rtukit;
using test::bytes;
using test::hex;

static_assert(!RTUKIT_CORE_MASTER && !RTUKIT_CORE_TCP && !RTUKIT_CORE_COILS && !RTUKIT_CORE_DIAGNOSTICS &&
                  !RTUKIT_CORE_IDENTIFICATION && !RTUKIT_CORE_MASK_WRITE && !RTUKIT_CORE_READ_WRITE,
              "this test runs against the core with every switch off");
static_assert(!kCoreComplete);

namespace {

// 16 holding registers, 4 input registers, coils it would serve; it declares
// every function, so a 01 comes from the core, not from the bank.
class Bank : public RegisterBank {
 public:
  std::array<uint16_t, 16> holding{};
  int coil_calls = 0;
  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    if (size_t{address} + out.size() > holding.size()) return Errc::illegal_data_address;
    std::copy_n(holding.begin() + address, out.size(), out.begin());
    return Errc::ok;
  }
  Errc read_input_registers(uint16_t address, std::span<uint16_t> out) override {
    if (size_t{address} + out.size() > 4) return Errc::illegal_data_address;
    for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint16_t>(0x100 + address + i);
    return Errc::ok;
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    if (size_t{address} + values.size() > holding.size()) return Errc::illegal_data_address;
    std::copy(values.begin(), values.end(), holding.begin() + address);
    return Errc::ok;
  }
  Errc read_coils(uint16_t, uint16_t, std::span<uint8_t>) override {
    ++coil_calls;
    return Errc::ok;
  }
  Errc write_coils(uint16_t, uint16_t, std::span<const uint8_t>) override {
    ++coil_calls;
    return Errc::ok;
  }
  FunctionSet functions() const noexcept override { return ~FunctionSet{0}; }
  std::string_view device_object(uint8_t) override { return "ACME"; }
};

// `frame_without_crc` gets its CRC, goes through a framer (as a driver does:
// a function compiled out has no predicted length, silence ends it) and the
// engine; the answer as hex ("" = silence).
std::string answer(SlaveEngine& engine, const std::string& frame_without_crc) {
  const auto body = bytes(frame_without_crc);
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  const size_t n = *rtu_encode(body[0], std::span(body).subspan(1), adu);
  RtuFramer framer(FrameShape::request, RtuTiming::for_serial(9600));
  framer.feed({adu.data(), n}, 0);
  auto frame = framer.next(0);
  if (!frame) frame = framer.next(1'000'000);
  if (!frame) return "(no frame)";
  std::array<uint8_t, kMaxRtuAduSize> out{};
  return hex({out.data(), engine.handle_rtu(frame->adu, out).length});
}

std::string with_crc(const std::string& frame_without_crc) {
  const auto body = bytes(frame_without_crc);
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  return hex({adu.data(), *rtu_encode(body[0], std::span(body).subspan(1), adu)});
}

class CoreMinimal : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok()); }
  Bank bank;
  SlaveEngine engine;
};

}  // namespace

TEST_F(CoreMinimal, RegisterFunctions_Answered) {
  bank.holding[0] = 0x15;
  EXPECT_EQ(answer(engine, "01 03 00 00 00 01"), "01 03 02 00 15 79 8B");
  EXPECT_EQ(answer(engine, "01 04 00 01 00 02"), with_crc("01 04 04 01 01 01 02"));
  EXPECT_EQ(answer(engine, "01 06 00 05 00 2A"), "01 06 00 05 00 2A 18 14");
  EXPECT_EQ(answer(engine, "01 10 00 02 00 02 04 00 07 00 08"), with_crc("01 10 00 02 00 02"));
  EXPECT_EQ(bank.holding[5], 42);
  EXPECT_EQ(bank.holding[2], 7);
  EXPECT_EQ(bank.holding[3], 8);
}

TEST_F(CoreMinimal, ExceptionsInTheSpecificationsOrder) {
  EXPECT_EQ(answer(engine, "01 03 00 00 00 7E"), with_crc("01 83 03"));  // quantity 126
  EXPECT_EQ(answer(engine, "01 03 00 0F 00 02"), with_crc("01 83 02"));  // past the bank's table
  EXPECT_EQ(answer(engine, "01 10 00 00 00 02 03 00 07 00"), with_crc("01 90 03"));  // byte count
}

TEST_F(CoreMinimal, EveryFunctionCompiledOut_Exception01) {
  const char* requests[] = {
      "01 01 00 00 00 08",                    // read coils
      "01 02 00 00 00 08",                    // read discrete inputs
      "01 05 00 00 FF 00",                    // write single coil
      "01 0F 00 00 00 08 01 FF",              // write multiple coils
      "01 07",                                // read exception status
      "01 08 00 00 A5 37",                    // diagnostics: return query data
      "01 08 00 04 00 00",                    // diagnostics: force listen only
      "01 0B",                                // get comm event counter
      "01 0C",                                // get comm event log
      "01 11",                                // report server id
      "01 2B 0E 01 00",                       // read device identification
      "01 16 00 04 00 F2 00 25",              // mask write register
      "01 17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF",  // read/write multiple registers
  };
  for (const char* request : requests) {
    const uint8_t function = bytes(request)[1];
    EXPECT_FALSE(is_supported_function(function)) << request;
    const std::string exception = with_crc("01 " + hex(std::array{static_cast<uint8_t>(function | 0x80)}) + " 01");
    EXPECT_EQ(answer(engine, request), exception) << request;
  }
  EXPECT_EQ(bank.coil_calls, 0);
  EXPECT_FALSE(engine.listen_only());  // FC08 04 did not mute it
  EXPECT_EQ(answer(engine, "01 03 00 00 00 01"), "01 03 02 00 00 B8 44");
}

TEST_F(CoreMinimal, BroadcastWriteRuns_CoilBroadcastDoesNot) {
  EXPECT_EQ(answer(engine, "00 06 00 01 00 09"), "");
  EXPECT_EQ(bank.holding[1], 9);
  EXPECT_EQ(answer(engine, "00 05 00 00 FF 00"), "");
  EXPECT_EQ(bank.coil_calls, 0);
  EXPECT_EQ(engine.counters().broadcasts, 2U);
}
