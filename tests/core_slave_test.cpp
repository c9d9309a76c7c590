// Slave engine exception matrix and master transaction checks, wire bytes in,
// wire bytes out.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "rtukit/core.hpp"
#include "wire.hpp"

using namespace rtukit;
using test::bytes;
using test::hex;

namespace {

// 100 holding registers at 0..99 accepting 0..1000; 10 coils; no input tables.
class TestBank : public RegisterBank {
 public:
  FrameQuirks accepted{};
  FrameQuirks quirks() const noexcept override { return accepted; }
  std::array<uint16_t, 100> holding{};
  std::array<uint8_t, 10> coils{};
  int writes = 0;

  Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    if (size_t{address} + out.size() > holding.size()) return Errc::illegal_data_address;
    std::copy_n(holding.begin() + address, out.size(), out.begin());
    return Errc::ok;
  }
  Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    if (size_t{address} + values.size() > holding.size()) return Errc::illegal_data_address;
    for (uint16_t v : values)
      if (v > 1000) return Errc::illegal_data_value;  // validated whole, before any change
    std::copy(values.begin(), values.end(), holding.begin() + address);
    ++writes;
    return Errc::ok;
  }
  Errc read_coils(uint16_t address, uint16_t count, std::span<uint8_t> out) override {
    if (size_t{address} + count > coils.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < count; ++i) set_bit(out, i, coils[address + i] != 0);
    return Errc::ok;
  }
  Errc write_coils(uint16_t address, uint16_t count, std::span<const uint8_t> packed) override {
    if (size_t{address} + count > coils.size()) return Errc::illegal_data_address;
    for (size_t i = 0; i < count; ++i) coils[address + i] = get_bit(packed, i);
    return Errc::ok;
  }
};

// Frame in (CRC appended here), frame out as hex ("" = silence).
std::string answer(SlaveEngine& engine, const std::string& frame_without_crc) {
  const auto body = bytes(frame_without_crc);
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  const size_t n = *rtu_encode(body[0], std::span(body).subspan(1), adu);
  std::array<uint8_t, kMaxRtuAduSize> out{};
  const size_t m = engine.handle_rtu({adu.data(), n}, out).length;
  return hex({out.data(), m});
}

// The same, through the framer first (as a driver does), so unknown lengths work.
std::string answer_framed(SlaveEngine& engine, const std::string& full_frame) {
  RtuFramer framer(FrameShape::request, RtuTiming::for_serial(9600));
  const auto in = bytes(full_frame);
  framer.feed(in, 0);
  auto frame = framer.next(0);
  if (!frame) frame = framer.next(1'000'000);  // silence ends an unpredictable frame
  if (!frame) return "(no frame)";
  std::array<uint8_t, kMaxRtuAduSize> out{};
  return hex({out.data(), engine.handle_rtu(frame->adu, out).length});
}

// Exception response for `unit`, `fc`, `code` with its CRC, as hex.
std::string exception(uint8_t unit, uint8_t fc, uint8_t code) {
  const uint8_t pdu[] = {static_cast<uint8_t>(fc | 0x80), code};
  std::array<uint8_t, 8> adu{};
  return hex({adu.data(), *rtu_encode(unit, pdu, adu)});
}

class SlaveEngineTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok()); }
  TestBank bank;
  SlaveEngine engine;
};

}  // namespace

TEST_F(SlaveEngineTest, ReadAndWrite_Answered) {
  bank.holding[0] = 0x15;
  EXPECT_EQ(answer(engine, "01 03 00 00 00 01"), "01 03 02 00 15 79 8B");
  EXPECT_EQ(answer(engine, "01 06 00 05 00 2A"), "01 06 00 05 00 2A 18 14");
  EXPECT_EQ(bank.holding[5], 42);
}

TEST_F(SlaveEngineTest, UnknownFunction_Exception01_EvenThoughItsLengthIsUnknown) {
  EXPECT_EQ(answer_framed(engine, "01 2B 0E 01 00 77 77"), "(no frame)");  // bad CRC: silence
  const auto body = bytes("01 2B 0E 01 00");
  std::array<uint8_t, 16> adu{};
  const size_t n = *rtu_encode(1, std::span(body).subspan(1), adu);
  EXPECT_EQ(answer_framed(engine, hex({adu.data(), n})), exception(1, 0x2B, 0x01));
  EXPECT_EQ(answer(engine, "01 07"), exception(1, 0x07, 0x01));
}

TEST_F(SlaveEngineTest, UnimplementedTable_Exception01) {
  EXPECT_EQ(answer(engine, "01 04 00 00 00 01"), exception(1, 0x04, 0x01));  // no input registers
}

TEST_F(SlaveEngineTest, Fc10Quantity0_126_124_Exception03) {
  EXPECT_EQ(answer(engine, "01 10 00 00 00 00 00"), exception(1, 0x10, 0x03));
  // 124 registers cannot fit an RTU frame (257 bytes): a master that tries
  // sends what fits, and the length disagrees with the quantity.
  std::string q124 = "01 10 00 00 00 7C F8";
  for (int i = 0; i < 246; ++i) q124 += " 00";
  EXPECT_EQ(answer(engine, q124), exception(1, 0x10, 0x03));
  std::string q126 = "01 10 00 00 00 7E FC";
  for (int i = 0; i < 252 - 10; ++i) q126 += " 00";  // cannot even fit: length disagrees
  EXPECT_EQ(answer(engine, q126), exception(1, 0x10, 0x03));
  EXPECT_EQ(bank.writes, 0);
}

TEST_F(SlaveEngineTest, ReadQuantity126_Exception03) {
  EXPECT_EQ(answer(engine, "01 03 00 00 00 7E"), exception(1, 0x03, 0x03));
}

TEST_F(SlaveEngineTest, AddressOverflowPast0xFFFF_Exception02) {
  EXPECT_EQ(answer(engine, "01 03 FF FF 00 02"), exception(1, 0x03, 0x02));
  EXPECT_EQ(answer(engine, "01 10 FF FF 00 02 04 00 01 00 02"), exception(1, 0x10, 0x02));
}

TEST_F(SlaveEngineTest, ByteCountDisagreeingWithQuantity_Exception03) {
  EXPECT_EQ(answer(engine, "01 10 00 00 00 02 02 00 01"), exception(1, 0x10, 0x03));
  EXPECT_EQ(answer(engine, "01 0F 00 00 00 09 01 FF"), exception(1, 0x0F, 0x03));
  EXPECT_EQ(bank.writes, 0);
}

TEST_F(SlaveEngineTest, OutOfRangeForTheDevice_Exception02) {
  EXPECT_EQ(answer(engine, "01 03 00 63 00 02"), exception(1, 0x03, 0x02));
}

TEST_F(SlaveEngineTest, MultiWrite_IsAllOrNothing) {
  EXPECT_EQ(answer(engine, "01 10 00 00 00 03 06 00 01 00 02 FF FF"), exception(1, 0x10, 0x03));
  EXPECT_EQ(bank.holding[0], 0);
  EXPECT_EQ(bank.holding[1], 0);
  EXPECT_EQ(answer(engine, "01 10 00 00 00 03 06 00 01 00 02 00 03"), "01 10 00 00 00 03 80 08");
  EXPECT_EQ(bank.holding[2], 3);
}

TEST_F(SlaveEngineTest, Fc10WithoutByteCount_IsAccepted) {
  bank.accepted.fc10_without_byte_count = true;  // a device documented to use it (the Inverjet)
  EXPECT_EQ(answer(engine, "01 10 00 21 00 02 00 07 00 08"), "01 10 00 21 00 02 11 C2");
  EXPECT_EQ(bank.holding[0x21], 7);
  EXPECT_EQ(bank.holding[0x22], 8);
}

TEST_F(SlaveEngineTest, Fc10WithoutByteCount_IsRefusedUnlessTheDeviceOptsIn) {
  EXPECT_EQ(answer(engine, "01 10 00 21 00 02 00 07 00 08").substr(0, 5), "01 90");  // 03: count disagrees
  EXPECT_EQ(bank.holding[0x21], 0);
}

// A standard FC10 whose last register was cut off in transit looks like the
// short form by its length. Over Modbus TCP the quirk never applies: the
// request gets 03 and nothing is written shifted.
TEST_F(SlaveEngineTest, TruncatedFc10OverTcp_Gets03EvenWithTheQuirkOn) {
  bank.accepted.fc10_without_byte_count = true;
  // FC10 at 0x21, quantity 2, byte count 4, but only one register (00 07) arrived.
  const auto adu = bytes("00 01 00 00 00 08 01 10 00 21 00 02 04 00 07");
  std::array<uint8_t, kMaxMbapAduSize> out{};
  const size_t n = engine.handle_tcp(adu, out).length;
  EXPECT_EQ(hex({out.data(), n}), "00 01 00 00 00 03 01 90 03");
  EXPECT_EQ(bank.holding[0x21], 0);
  EXPECT_EQ(bank.holding[0x22], 0);
}

TEST_F(SlaveEngineTest, BroadcastRead_IsSilentAndNotExecuted) {
  EXPECT_EQ(answer(engine, "00 03 00 00 00 01"), "");
  EXPECT_EQ(engine.counters().broadcasts, 1U);
}

TEST_F(SlaveEngineTest, BroadcastWrite_IsExecutedSilently) {
  EXPECT_EQ(answer(engine, "00 06 00 07 00 09"), "");
  EXPECT_EQ(bank.holding[7], 9);
  EXPECT_EQ(answer(engine, "00 10 00 08 00 02 04 00 01 00 02"), "");
  EXPECT_EQ(bank.holding[9], 2);
}

TEST_F(SlaveEngineTest, FrameForAnotherUnit_IsSilent) {
  EXPECT_EQ(answer(engine, "02 06 00 07 00 09"), "");
  EXPECT_EQ(bank.holding[7], 0);
  EXPECT_EQ(engine.counters().ignored, 1U);
}

TEST_F(SlaveEngineTest, Coils_ReadAndWrite) {
  EXPECT_EQ(answer(engine, "01 05 00 02 FF 00"), "01 05 00 02 FF 00 2D FA");
  EXPECT_EQ(answer(engine, "01 0F 00 04 00 03 01 05"), "01 0F 00 04 00 03 54 0B");
  EXPECT_EQ(answer(engine, "01 01 00 00 00 08"), "01 01 01 54 50 77");  // bits 2, 4, 6
}

TEST_F(SlaveEngineTest, SeveralUnitsOnOneBus) {
  TestBank other;
  ASSERT_TRUE(engine.add_unit(UnitId{21}, other).ok());
  EXPECT_FALSE(engine.add_unit(UnitId{21}, other).ok());
  EXPECT_EQ(answer(engine, "15 06 00 00 00 0C"), "15 06 00 00 00 0C 8A DB");
  EXPECT_EQ(other.holding[0], 12);
  EXPECT_EQ(bank.holding[0], 0);
  ASSERT_TRUE(engine.change_unit_address(UnitId{21}, UnitId{12}).ok());
  EXPECT_EQ(answer(engine, "15 03 00 00 00 01"), "");
  EXPECT_NE(answer(engine, "0C 03 00 00 00 01"), "");
  // Broadcast reaches every unit.
  EXPECT_EQ(answer(engine, "00 06 00 01 00 05"), "");
  EXPECT_EQ(bank.holding[1], 5);
  EXPECT_EQ(other.holding[1], 5);
}

TEST_F(SlaveEngineTest, ModbusTcp_EchoesTheHeader) {
  bank.holding[0] = 0x15;
  const auto adu = bytes("12 34 00 00 00 06 01 03 00 00 00 01");
  std::array<uint8_t, kMaxMbapAduSize> out{};
  const size_t n = engine.handle_tcp(adu, out).length;
  EXPECT_EQ(hex({out.data(), n}), "12 34 00 00 00 05 01 03 02 00 15");
  // Unit 0xFF addresses the device itself on TCP.
  const auto ff = bytes("00 01 00 00 00 06 FF 03 00 00 00 01");
  EXPECT_EQ(hex({out.data(), engine.handle_tcp(ff, out).length}), "00 01 00 00 00 05 FF 03 02 00 15");
}

TEST(MasterTransaction, RtuRequestAndResponse) {
  MasterTransaction tx;
  Request r;
  r.function = 0x03;
  r.address = 0x0021;
  r.quantity = 4;
  ASSERT_TRUE(tx.begin(Framing::rtu, UnitId{0x15}, r).ok());
  EXPECT_EQ(hex(tx.request_bytes()), "15 03 00 21 00 04 17 17");
  RtuFramer f(FrameShape::response);
  tx.prepare(f, false);
  f.feed(bytes("16 03 02 00 15 0D 88 15 03 08 00 00 00 06 00 50 07 08 5F C0"), 0);
  auto other = f.next(0);  // unit 0x16: not ours
  ASSERT_TRUE(other);
  EXPECT_FALSE(tx.accept_rtu(*other).has_value());
  auto mine = f.next(0);
  ASSERT_TRUE(mine);
  auto outcome = tx.accept_rtu(*mine);
  ASSERT_TRUE(outcome.has_value());
  ASSERT_TRUE(outcome->ok()) << outcome->error().name();
  std::array<uint16_t, 4> regs{};
  load_registers((*outcome)->data, regs);
  EXPECT_EQ(regs, (std::array<uint16_t, 4>{0, 6, 80, 1800}));
}

TEST(MasterTransaction, ExceptionComesBackAsTheError) {
  MasterTransaction tx;
  Request r;
  r.function = 0x03;
  r.address = 0x0005;
  r.quantity = 1;
  ASSERT_TRUE(tx.begin(Framing::rtu, UnitId{0x15}, r).ok());
  RtuFramer f(FrameShape::response);
  f.feed(bytes("15 83 02 80 F5"), 0);
  auto frame = f.next(0);
  ASSERT_TRUE(frame);
  auto outcome = tx.accept_rtu(*frame);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->error().code(), Errc::illegal_data_address);
}

TEST(MasterTransaction, BroadcastReadIsRefused_BroadcastWriteExpectsNothing) {
  MasterTransaction tx;
  Request r;
  r.function = 0x03;
  r.quantity = 1;
  EXPECT_EQ(tx.begin(Framing::rtu, kBroadcast, r).code(), Errc::invalid_argument);
  r.function = 0x06;
  r.value = 1;
  ASSERT_TRUE(tx.begin(Framing::rtu, kBroadcast, r).ok());
  EXPECT_FALSE(tx.expects_response());
}

TEST(MasterTransaction, TcpMatchesTheTransactionId) {
  MasterTransaction tx;
  Request r;
  r.function = 0x03;
  r.quantity = 1;
  ASSERT_TRUE(tx.begin(Framing::tcp, UnitId{1}, r, 7).ok());
  EXPECT_EQ(hex(tx.request_bytes()), "00 07 00 00 00 06 01 03 00 00 00 01");
  EXPECT_FALSE(tx.accept_tcp(bytes("00 06 00 00 00 05 01 03 02 00 15")).has_value());  // stale
  auto outcome = tx.accept_tcp(bytes("00 07 00 00 00 05 01 03 02 00 15"));
  ASSERT_TRUE(outcome.has_value());
  EXPECT_TRUE(outcome->ok());
}

// ---- FC16 mask write and FC17 read/write multiple (issue 14) ----

namespace {

// A bank that declares the combined register functions.
class CombinedBank : public TestBank {
 public:
  FunctionSet functions() const noexcept override { return kDataFunctions | kRegisterCombinedFunctions; }
};

// The frame with its CRC, as hex.
std::string framed(const std::string& frame_without_crc) {
  const auto body = bytes(frame_without_crc);
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  return hex({adu.data(), *rtu_encode(body[0], std::span(body).subspan(1), adu)});
}

class CombinedTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok()); }
  CombinedBank bank;
  SlaveEngine engine;
};

}  // namespace

// The specification's example (MODBUS Application Protocol 1.1b3, 6.16):
// register 4 holds 0x12; AND 0xF2, OR 0x25 gives 0x17; the answer echoes.
TEST_F(CombinedTest, MaskWrite_SpecificationExample) {
  bank.holding[4] = 0x12;
  EXPECT_EQ(answer(engine, "01 16 00 04 00 F2 00 25"), framed("01 16 00 04 00 F2 00 25"));
  EXPECT_EQ(bank.holding[4], 0x17);
  EXPECT_EQ(answer(engine, "01 16 00 C8 00 F2 00 25"), exception(1, 0x16, 0x02));  // no register 200
  EXPECT_EQ(answer(engine, "01 16 00 04 00 F2"), "");                              // too short: silence
  EXPECT_EQ(answer(engine, "01 16 00 04 00 F2 00 25 00"), exception(1, 0x16, 0x03));
}

// The specification's example (6.17): write 3 registers at 0x0E, read 6 from 3.
TEST_F(CombinedTest, ReadWriteMultiple_SpecificationExample) {
  const uint16_t before[] = {0x00FE, 0x0ACD, 0x0001, 0x0003, 0x000D, 0x00FF};
  std::copy(std::begin(before), std::end(before), bank.holding.begin() + 3);
  EXPECT_EQ(answer(engine, "01 17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF"),
            framed("01 17 0C 00 FE 0A CD 00 01 00 03 00 0D 00 FF"));
  EXPECT_EQ(bank.holding[14], 0xFF);
  EXPECT_EQ(bank.holding[16], 0xFF);
}

TEST_F(CombinedTest, ReadWriteMultiple_TheWriteComesFirst) {
  EXPECT_EQ(answer(engine, "01 17 00 05 00 02 00 05 00 01 02 01 F4"), framed("01 17 04 01 F4 00 00"));
}

// All or nothing: a read that must fail answers 02 without the write applied;
// a value the bank refuses writes nothing either.
TEST_F(CombinedTest, ReadWriteMultiple_IsAllOrNothing) {
  EXPECT_EQ(answer(engine, "01 17 00 62 00 05 00 00 00 01 02 00 07"), exception(1, 0x17, 0x02));
  EXPECT_EQ(bank.writes, 0);
  EXPECT_EQ(bank.holding[0], 0);
  EXPECT_EQ(answer(engine, "01 17 00 00 00 01 00 00 00 02 04 00 07 13 88"), exception(1, 0x17, 0x03));
  EXPECT_EQ(bank.writes, 0);
}

TEST_F(CombinedTest, ReadWriteMultiple_ExceptionMatrix) {
  const std::pair<const char*, uint8_t> cases[] = {
      {"01 17 00 00 00 00 00 00 00 01 02 00 07", 0x03},        // read quantity 0
      {"01 17 00 00 00 7E 00 00 00 01 02 00 07", 0x03},        // read quantity 126
      {"01 17 00 00 00 01 00 00 00 00 00", 0x03},              // write quantity 0
      {"01 17 00 00 00 01 00 00 00 02 03 00 07 00", 0x03},     // byte count 3 for 2 registers
      {"01 17 FF FF 00 02 00 00 00 01 02 00 07", 0x02},        // read past 0xFFFF
      {"01 17 00 00 00 01 FF FF 00 02 04 00 07 00 07", 0x02},  // write past 0xFFFF
  };
  for (const auto& [frame, code] : cases) EXPECT_EQ(answer(engine, frame), exception(1, 0x17, code)) << frame;
  // Write quantity 122 (121 is the most; 122 would not fit a frame): 03.
  EXPECT_EQ(answer(engine, "01 17 00 00 00 01 00 00 00 7A 02 00 01"), exception(1, 0x17, 0x03));
  EXPECT_EQ(bank.writes, 0);
}

TEST_F(CombinedTest, Broadcast_MaskWriteRuns_ReadWriteDoesNot) {
  bank.holding[4] = 0x12;
  EXPECT_EQ(answer(engine, "00 16 00 04 00 F2 00 25"), "");
  EXPECT_EQ(bank.holding[4], 0x17);
  EXPECT_EQ(answer(engine, "00 17 00 00 00 01 00 07 00 01 02 00 07"), "");
  EXPECT_EQ(bank.holding[7], 0);
}

// A device that does not declare them answers 01 (the built-in profiles).
TEST_F(SlaveEngineTest, MaskWriteAndReadWrite_Are01UnlessTheBankDeclaresThem) {
  EXPECT_EQ(answer(engine, "01 16 00 04 00 F2 00 25"), exception(1, 0x16, 0x01));
  EXPECT_EQ(answer(engine, "01 17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF"), exception(1, 0x17, 0x01));
}

// The framer knows both lengths, in both directions, byte by byte.
TEST(RtuFramerCombined, PredictsMaskWriteAndReadWriteLengths) {
  for (const auto& [shape, text] : std::vector<std::pair<FrameShape, std::string>>{
           {FrameShape::request, framed("01 16 00 04 00 F2 00 25")},
           {FrameShape::request, framed("01 17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF")},
           {FrameShape::response, framed("01 16 00 04 00 F2 00 25")},
           {FrameShape::response, framed("01 17 0C 00 FE 0A CD 00 01 00 03 00 0D 00 FF")}}) {
    RtuFramer f(shape);  // no timing: the length must be predicted
    const auto in = bytes(text);
    for (size_t i = 0; i + 1 < in.size(); ++i) {
      f.feed({&in[i], 1}, 0);
      EXPECT_FALSE(f.next(0)) << text << " early at " << i;
    }
    f.feed({&in.back(), 1}, 0);
    const auto frame = f.next(0);
    ASSERT_TRUE(frame) << text;
    EXPECT_EQ(hex(frame->adu), text);
  }
}

// The codec: the specification's request bytes, and the master's checks.
TEST(CombinedCodec, EncodeAndDecode) {
  std::array<uint8_t, kMaxPduSize> out{};
  auto n = encode_mask_write_register(4, 0x00F2, 0x0025, out);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(hex({out.data(), *n}), "16 00 04 00 F2 00 25");
  const auto values = bytes("00 FF 00 FF 00 FF");
  n = encode_read_write_multiple_registers(3, 6, 0x0E, values, out);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(hex({out.data(), *n}), "17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF");
  EXPECT_FALSE(encode_read_write_multiple_registers(3, 126, 0, values, out).ok());  // read 126

  const Result<Request> rw = decode_request({out.data(), *n});
  ASSERT_TRUE(rw.ok());
  EXPECT_EQ(rw->address, 3);
  EXPECT_EQ(rw->quantity, 6);
  EXPECT_EQ(rw->write_address, 0x0E);
  EXPECT_EQ(rw->write_quantity, 3);
  const auto answer_pdu = bytes("17 0C 00 FE 0A CD 00 01 00 03 00 0D 00 FF");
  const Result<Response> r = decode_response(*rw, answer_pdu);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->data.size(), 12u);
  EXPECT_EQ(decode_response(*rw, bytes("17 02 00 FE")).error().code(), Errc::unexpected_response);

  Request mask;
  mask.function = 0x16;
  mask.address = 4;
  mask.and_mask = 0xF2;
  mask.or_mask = 0x25;
  EXPECT_TRUE(decode_response(mask, bytes("16 00 04 00 F2 00 25")).ok());
  EXPECT_EQ(decode_response(mask, bytes("16 00 04 00 F2 00 26")).error().code(), Errc::unexpected_response);
  EXPECT_EQ(decode_response(mask, bytes("96 02")).error().code(), Errc::illegal_data_address);
}

// ---- serial line diagnostics and identification (issue 14) ----

namespace {

// Declares everything; the specification's example identification.
class FullBank : public CombinedBank {
 public:
  FunctionSet functions() const noexcept override {
    return kDataFunctions | kRegisterCombinedFunctions | kDiagnosticFunctions | kIdentificationFunctions;
  }
  uint8_t status = 0x6D;
  uint8_t exception_status() override { return status; }
  std::map<uint8_t, std::string> objects{{0, "Company identification"}, {1, "Product code XX"}, {2, "V2.11"}};
  std::string_view device_object(uint8_t id) override {
    const auto it = objects.find(id);
    return it == objects.end() ? std::string_view() : std::string_view(it->second);
  }
};

class DiagTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok()); }
  // "01 " + the PDU as hex, through the engine; the answer's PDU as hex.
  std::string pdu_answer(const std::string& pdu) {
    const std::string got = answer(engine, "01 " + pdu);
    if (got.size() < 9) return got;
    return got.substr(3, got.size() - 9);  // without the address and the CRC
  }
  FullBank bank;
  SlaveEngine engine;
};

std::string fmt_hex(uint8_t b) {
  return hex(std::vector<uint8_t>{b});
}

std::string text_hex(const std::string& s) {
  return hex({reinterpret_cast<const uint8_t*>(s.data()), s.size()});
}

}  // namespace

// The specification's examples (MODBUS Application Protocol 1.1b3, 6.7, 6.8).
TEST_F(DiagTest, ExceptionStatusAndReturnQueryData_SpecificationExamples) {
  EXPECT_EQ(pdu_answer("07"), "07 6D");
  EXPECT_EQ(pdu_answer("08 00 00 A5 37"), "08 00 00 A5 37");
  EXPECT_EQ(pdu_answer("08 00 00"), "08 00 00");  // no data at all
}

TEST_F(DiagTest, CountersMatchWhatTheLineSaw) {
  engine.note_crc_errors(3);                                  // three frames failed their CRC
  EXPECT_EQ(answer(engine, "02 03 00 00 00 01"), "");         // another unit's request
  EXPECT_EQ(pdu_answer("03 00 00 00 01"), "03 02 00 00");     // ours
  EXPECT_EQ(pdu_answer("03 00 C8 00 01"), "83 02");           // exception 02
  EXPECT_EQ(pdu_answer("41"), "C1 01");                       // exception 01
  EXPECT_EQ(answer(engine, "00 06 00 01 00 07"), "");         // a broadcast: no answer
  EXPECT_EQ(pdu_answer("08 00 0B 00 00"), "08 00 0B 00 06");  // bus messages (this one too)
  EXPECT_EQ(pdu_answer("08 00 0C 00 00"), "08 00 0C 00 03");  // CRC errors
  EXPECT_EQ(pdu_answer("08 00 0D 00 00"), "08 00 0D 00 02");  // exceptions
  EXPECT_EQ(pdu_answer("08 00 0E 00 00"), "08 00 0E 00 08");  // to us: 5 + broadcast + these 3... = 8
  EXPECT_EQ(pdu_answer("08 00 0F 00 00"), "08 00 0F 00 01");  // unanswered: the broadcast
  EXPECT_EQ(pdu_answer("08 00 10 00 00"), "08 00 10 00 00");  // NAK
  EXPECT_EQ(pdu_answer("08 00 11 00 00"), "08 00 11 00 00");  // busy
  EXPECT_EQ(pdu_answer("08 00 12 00 00"), "08 00 12 00 00");  // overruns
  EXPECT_EQ(pdu_answer("08 00 02 00 00"), "08 00 02 00 00");  // diagnostic register
  EXPECT_EQ(engine.line_counters().bus_crc_errors, 3u);
  // Clear: every counter back to 0 (the clear itself is counted afterwards).
  EXPECT_EQ(pdu_answer("08 00 0A 00 00"), "08 00 0A 00 00");
  EXPECT_EQ(pdu_answer("08 00 0C 00 00"), "08 00 0C 00 00");
  EXPECT_EQ(pdu_answer("08 00 0D 00 00"), "08 00 0D 00 00");
  EXPECT_EQ(pdu_answer("08 00 0B 00 00"), "08 00 0B 00 03");  // the two reads above and this one
}

TEST_F(DiagTest, SubFunctionMatrix) {
  for (const char* unsupported : {"08 00 03 0A 00", "08 00 13 00 00", "08 00 15 00 00", "08 FF FF 00 00"})
    EXPECT_EQ(pdu_answer(unsupported), "88 01") << unsupported;
  EXPECT_EQ(pdu_answer("08 00 0B 00 01"), "88 03");  // counters take 0x0000
  EXPECT_EQ(pdu_answer("08 00 01 12 34"), "88 03");  // restart takes 0000 or FF00
  EXPECT_EQ(pdu_answer("08 00 0B 00"), "88 03");     // a short data field
  EXPECT_EQ(pdu_answer("08 00"), "");                // no sub-function at all: dropped
  EXPECT_EQ(pdu_answer("07 00"), "87 03");
}

// Listen-only mode really makes the slave silent (and inert) until "restart
// communications", which is not answered either.
TEST_F(DiagTest, ListenOnlyUntilRestart) {
  EXPECT_EQ(pdu_answer("08 00 04 00 00"), "");  // force listen only: no answer
  EXPECT_TRUE(engine.listen_only());
  EXPECT_EQ(pdu_answer("06 00 01 00 07"), "");  // not answered...
  EXPECT_EQ(bank.holding[1], 0);                // ...and not executed
  EXPECT_EQ(answer(engine, "00 06 00 01 00 07"), "");
  EXPECT_EQ(bank.holding[1], 0);                // not even a broadcast
  EXPECT_EQ(pdu_answer("08 00 0B 00 00"), "");  // diagnostics neither
  EXPECT_EQ(pdu_answer("08 00 01 00 00"), "");  // restart: leaves the mode, silently
  EXPECT_FALSE(engine.listen_only());
  EXPECT_EQ(pdu_answer("06 00 01 00 07"), "06 00 01 00 07");
  EXPECT_EQ(bank.holding[1], 7);
  EXPECT_EQ(pdu_answer("08 00 01 FF 00"), "08 00 01 FF 00");  // restart when listening: echoed
}

// FC0B and FC0C: the event counter counts completed requests (not the polls
// of it, not exceptions); the log holds the events, the newest first.
TEST_F(DiagTest, CommEventCounterAndLog) {
  EXPECT_EQ(pdu_answer("08 00 01 FF 00"), "08 00 01 FF 00");  // restart, clear the log
  EXPECT_EQ(pdu_answer("03 00 00 00 01"), "03 02 00 00");
  EXPECT_EQ(pdu_answer("03 00 C8 00 01"), "83 02");
  EXPECT_EQ(pdu_answer("0B"), "0B 00 00 00 02");  // the restart's echo and the read
  EXPECT_EQ(pdu_answer("0B"), "0B 00 00 00 02");  // polling it does not count
  // Byte count 6 + 10 events, status 0, 2 events counted, 5 messages; then
  // (newest first) received FC0C, sent, received, sent (FC0B), received,
  // sent read exception, received, sent, received, sent (restart), restart.
  EXPECT_EQ(pdu_answer("0C"), "0C 11 00 00 00 02 00 05 80 40 80 40 80 41 80 40 80 40 00");
  // The 64 newest only.
  for (int i = 0; i < 40; ++i) pdu_answer("03 00 00 00 01");
  const std::string log = pdu_answer("0C");
  EXPECT_EQ(log.substr(0, 5), "0C 46");  // 6 + 64
}

// Identification: the specification's example stream (basic), regular and
// extended streams, individual access, "more follows".
TEST_F(DiagTest, ReadDeviceIdentification) {
  const std::string basic = "2B 0E 01 81 00 00 03 00 16 " + text_hex("Company identification") + " 01 0F " +
                            text_hex("Product code XX") + " 02 05 " + text_hex("V2.11");
  EXPECT_EQ(pdu_answer("2B 0E 01 00"), basic);
  EXPECT_EQ(pdu_answer("2B 0E 01 09"), basic);  // an object it does not have: from 0
  EXPECT_EQ(pdu_answer("2B 0E 01 02"), "2B 0E 01 81 00 00 01 02 05 " + text_hex("V2.11"));
  // A regular object: conformity 2; a regular stream includes the basic ones.
  bank.objects[4] = "Pump";
  EXPECT_EQ(pdu_answer("2B 0E 02 04"), "2B 0E 02 82 00 00 01 04 04 " + text_hex("Pump"));
  // Extended asked of a regular device: its own level.
  EXPECT_EQ(pdu_answer("2B 0E 03 04"), "2B 0E 03 82 00 00 01 04 04 " + text_hex("Pump"));
  // Individual access: one object, or 02.
  EXPECT_EQ(pdu_answer("2B 0E 04 01"), "2B 0E 04 82 00 00 01 01 0F " + text_hex("Product code XX"));
  EXPECT_EQ(pdu_answer("2B 0E 04 07"), "AB 02");
  EXPECT_EQ(pdu_answer("2B 0E 05 00"), "AB 03");
  EXPECT_EQ(pdu_answer("2B 0E 00 00"), "AB 03");
  EXPECT_EQ(pdu_answer("2B 0D 01 00"), "AB 01");  // MEI type 0D: not implemented
  // More follows: three 100-byte objects do not fit one response.
  bank.objects[0x80] = std::string(100, 'a');
  bank.objects[0x81] = std::string(100, 'b');
  bank.objects[0x82] = std::string(100, 'c');
  const std::string first = pdu_answer("2B 0E 03 80");
  EXPECT_EQ(first.substr(0, 20), "2B 0E 03 83 FF 82 02");  // two objects; the next is 0x82
  const std::string second = pdu_answer("2B 0E 03 82");
  EXPECT_EQ(second.substr(0, 20), "2B 0E 03 83 00 00 01");  // the last one
}

TEST_F(DiagTest, ReportServerId) {
  EXPECT_EQ(pdu_answer("11"), "11 " +
                                  hex(std::vector<uint8_t>{static_cast<uint8_t>(2 + 22 + 1 + 15 + 1 + 5)}) +
                                  " 01 FF " + text_hex("Company identification Product code XX V2.11"));
}

TEST_F(SlaveEngineTest, DiagnosticsAndIdentification_Are01UnlessDeclared) {
  for (const uint8_t f : {0x07, 0x08, 0x0B, 0x0C, 0x11, 0x2B}) {
    std::string pdu = fmt_hex(f);
    if (f == 0x08) pdu += " 00 00 A5 37";
    if (f == 0x2B) pdu += " 0E 01 00";
    EXPECT_EQ(answer(engine, "01 " + pdu), exception(1, f, 0x01)) << pdu;
  }
}

// The master's side: the specification's response examples decode.
TEST(DiagCodec, MasterDecodesTheSpecificationExamples) {
  Request r;
  r.function = 0x0B;
  const auto counter = bytes("0B FF FF 01 08");  // the response views these bytes
  auto got = decode_response(r, counter);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(hex(got->body), "FF FF 01 08");
  r.function = 0x0C;
  const auto log = bytes("0C 08 00 00 01 08 01 21 20 00");
  got = decode_response(r, log);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(hex(got->body), "08 00 00 01 08 01 21 20 00");
  EXPECT_FALSE(decode_response(r, bytes("0C 09 00 00 01 08 01 21 20 00")).ok());  // byte count wrong
  r.function = 0x08;
  r.sub_function = 0;
  EXPECT_TRUE(decode_response(r, bytes("08 00 00 A5 37")).ok());
  EXPECT_EQ(decode_response(r, bytes("08 00 01 A5 37")).error().code(), Errc::unexpected_response);
  r.function = 0x2B;
  r.read_code = 1;
  EXPECT_TRUE(decode_response(r, bytes("2B 0E 01 01 00 00 01 00 02 41 42")).ok());
  EXPECT_EQ(decode_response(r, bytes("2B 0E 01 01 00 00 01 00 05 41 42")).error().code(), Errc::malformed);
  EXPECT_EQ(decode_response(r, bytes("2B 0E 02 01 00 00 00")).error().code(), Errc::unexpected_response);
  std::array<uint8_t, 8> out{};
  r = Request{};
  r.function = 0x08;
  r.sub_function = 0x04;
  auto n = encode_request(r, out);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(hex({out.data(), *n}), "08 00 04 00 00");
}
