// RTU framer: frames from literal wire bytes, fed the way Linux delivers them.
#include <gtest/gtest.h>

#include "rtukit/core.hpp"
#include "wire.hpp"

using namespace rtukit;
using test::bytes;
using test::hex;

namespace {

// Feeds everything at time `t` and collects every frame, as hex.
std::vector<std::string> frames_of(RtuFramer& f, const std::vector<uint8_t>& in, uint64_t t = 0) {
  std::vector<std::string> out;
  size_t fed = 0;
  do {
    fed += f.feed(std::span(in).subspan(fed), t);
    while (auto frame = f.next(t)) out.push_back(hex(frame->adu));
  } while (fed < in.size());
  return out;
}

const char* const kRead = "15 03 00 21 00 04 17 17";
const char* const kWrite = "15 06 00 22 00 03 6A D5";

std::vector<uint8_t> with_crc(std::vector<uint8_t> frame) {
  const uint16_t crc = crc16(frame);
  frame.push_back(static_cast<uint8_t>(crc));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  return frame;
}

}  // namespace

TEST(RtuFramer, WholeFrame_IsReturnedOnce) {
  RtuFramer f(FrameShape::request);
  EXPECT_EQ(frames_of(f, bytes(kRead)), std::vector<std::string>{kRead});
  EXPECT_FALSE(f.next(0));
  EXPECT_EQ(f.counters().frames, 1U);
}

TEST(RtuFramer, SplitFrame_ByteByByte_IsAssembled) {
  RtuFramer f(FrameShape::request);
  const auto in = bytes("15 10 00 21 00 04 08 00 00 00 06 00 50 07 08 55 EE");
  std::vector<std::string> got;
  for (size_t i = 0; i < in.size(); ++i) {
    auto more = frames_of(f, {in[i]}, i * 100);
    got.insert(got.end(), more.begin(), more.end());
    if (i + 1 < in.size()) EXPECT_TRUE(got.empty()) << "early frame at byte " << i;
  }
  EXPECT_EQ(got, std::vector<std::string>{hex(in)});
}

TEST(RtuFramer, BackToBackFrames_InOneRead_AreAllReturned) {
  RtuFramer f(FrameShape::request);
  f.set_quirks({.fc10_without_byte_count = true});  // the last one is the Inverjet's short FC10
  auto in = bytes(std::string(kRead) + " " + kWrite + " 15 10 00 21 00 02 00 00 00 01 25 40");
  EXPECT_EQ(frames_of(f, in),
            (std::vector<std::string>{kRead, kWrite, "15 10 00 21 00 02 00 00 00 01 25 40"}));
}

TEST(RtuFramer, GarbageBeforeAFrame_IsSkipped) {
  for (const char* garbage :
       {"FF", "00 FF 13", "15 03 00", "01 10 00 00 00 7B F6 00", "AA 55 AA 55 AA 55 AA 55 AA"}) {
    RtuFramer f(FrameShape::request);
    EXPECT_EQ(frames_of(f, bytes(std::string(garbage) + " " + kRead)), std::vector<std::string>{kRead})
        << garbage;
    EXPECT_GT(f.counters().discarded_bytes, 0U);
  }
}

TEST(RtuFramer, GarbageThenSilenceThenFrame_WithTiming) {
  RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
  EXPECT_TRUE(frames_of(f, bytes("01 10 00 00 00 7B F6"), 0).empty());  // predicts a long frame
  EXPECT_EQ(frames_of(f, bytes(kRead), 50'000), std::vector<std::string>{kRead});
}

TEST(RtuFramer, FlippedBitAnywhere_IsNeverAccepted) {
  for (const char* text : {kRead, kWrite, "15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F"}) {
    const auto good = bytes(text);
    for (size_t bit = 0; bit < good.size() * 8; ++bit) {
      auto bad = good;
      bad[bit / 8] ^= static_cast<uint8_t>(1U << (bit % 8));
      RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
      f.set_quirks({.fc10_without_byte_count = true});  // with the short form's lengths in play too
      EXPECT_TRUE(frames_of(f, bad, 0).empty()) << text << " bit " << bit;
      EXPECT_FALSE(f.next(1'000'000)) << text << " bit " << bit;  // nor after silence
      // And the next good frame still gets through.
      EXPECT_EQ(frames_of(f, good, 2'000'000), std::vector<std::string>{text}) << text << " bit " << bit;
    }
  }
}

TEST(RtuFramer, EchoOfOurOwnRequest_IsDiscarded) {
  RtuFramer f(FrameShape::response);
  const auto request = bytes(kRead);
  f.expect_response(0x03, 4);
  f.expect_echo(request);
  const auto in = bytes(std::string(kRead) + " 15 03 08 00 00 00 00 00 00 00 00 D4 27");
  EXPECT_EQ(frames_of(f, in), std::vector<std::string>{"15 03 08 00 00 00 00 00 00 00 00 D4 27"});
  EXPECT_EQ(f.counters().echoes, 1U);
}

TEST(RtuFramer, EchoExpectedButAbsent_ResponseStillParsed) {
  RtuFramer f(FrameShape::response);
  f.expect_echo(bytes(kRead));
  EXPECT_EQ(frames_of(f, bytes("15 03 02 00 15 49 88")), std::vector<std::string>{"15 03 02 00 15 49 88"});
  EXPECT_EQ(f.counters().echoes, 0U);
}

TEST(RtuFramer, MaximumSizeFrames_BothDirections) {
  // FC10 with 123 registers: 255 bytes; FC03 response with 125 registers: 255 bytes.
  std::vector<uint8_t> pdu{0x10, 0x00, 0x00, 0x00, 123, 246};
  for (int i = 0; i < 246; ++i) pdu.push_back(static_cast<uint8_t>(i));
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  const size_t n = *rtu_encode(1, pdu, adu);
  ASSERT_EQ(n, 255U);
  RtuFramer req(FrameShape::request);
  const std::vector<uint8_t> in(adu.begin(), adu.begin() + static_cast<long>(n));
  EXPECT_EQ(frames_of(req, in), std::vector<std::string>{hex(in)});

  std::vector<uint8_t> rpdu{0x03, 250};
  for (int i = 0; i < 250; ++i) rpdu.push_back(static_cast<uint8_t>(255 - i));
  const size_t m = *rtu_encode(1, rpdu, adu);
  ASSERT_EQ(m, 255U);
  RtuFramer resp(FrameShape::response);
  const std::vector<uint8_t> rin(adu.begin(), adu.begin() + static_cast<long>(m));
  // Twice in one read, split oddly: the 512-byte buffer must cope.
  std::vector<uint8_t> two = rin;
  two.insert(two.end(), rin.begin(), rin.end());
  EXPECT_EQ(frames_of(resp, two), (std::vector<std::string>{hex(rin), hex(rin)}));
}

TEST(RtuFramer, UnknownFunction_EndsAtSilence) {
  RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
  const auto in = with_crc({0x15, 0x41, 0x0E, 0x01, 0x00});  // FC 41 (user-defined): length not predictable
  ASSERT_TRUE(rtu_crc_ok(in));
  EXPECT_TRUE(frames_of(f, in, 1000).empty());
  ASSERT_TRUE(f.silence_deadline().has_value());
  EXPECT_EQ(*f.silence_deadline(), 1000U + RtuTiming::for_serial(9600).t35_us);
  EXPECT_FALSE(f.next(1000 + 100));
  auto frame = f.next(1000 + 10'000);
  ASSERT_TRUE(frame);
  EXPECT_EQ(hex(frame->adu), hex(in));
}

TEST(RtuFramer, UnknownFunctionFollowedByAKnownFrame_WithoutTiming) {
  RtuFramer f(FrameShape::request);
  // Garbage with an unknown function byte, then a good frame: the good one wins.
  EXPECT_EQ(frames_of(f, bytes(std::string("42 99 01 02 ") + kRead)), std::vector<std::string>{kRead});
}

TEST(RtuFramer, TruncatedFrame_IsDroppedAtSilence) {
  RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
  EXPECT_TRUE(frames_of(f, bytes("15 03 00 21 00"), 0).empty());
  EXPECT_FALSE(f.next(100'000));
  EXPECT_EQ(f.buffered(), 0U);
  EXPECT_EQ(frames_of(f, bytes(kRead), 200'000), std::vector<std::string>{kRead});
}

TEST(RtuFramer, Fc10BothForms_AreRecognisedByLengthAndCrc) {
  RtuFramer f(FrameShape::request);
  f.set_quirks({.fc10_without_byte_count = true});
  const char* short_form = "15 10 00 21 00 02 00 02 00 0D 84 85";
  const char* standard = "15 10 00 21 00 02 04 00 02 00 0D 11 8E";
  EXPECT_EQ(frames_of(f, bytes(std::string(short_form) + " " + standard + " " + short_form)),
            (std::vector<std::string>{short_form, standard, short_form}));
}

TEST(RtuFramer, RehandTwoByteByteCount_WithAndWithoutExpectation) {
  const char* longer = "01 03 00 04 00 68 00 50 C2 E7";
  RtuFramer expecting(FrameShape::response);
  expecting.set_quirks({.fc03_two_byte_count = true});
  expecting.expect_response(0x03, 2);
  EXPECT_EQ(frames_of(expecting, bytes(longer)), std::vector<std::string>{longer});
  RtuFramer sniffing(FrameShape::response);
  sniffing.set_quirks({.fc03_two_byte_count = true});
  EXPECT_EQ(frames_of(sniffing, bytes(longer)), std::vector<std::string>{longer});
  EXPECT_EQ(frames_of(sniffing, bytes("01 03 04 00 68 00 50 7B D3")),
            std::vector<std::string>{"01 03 04 00 68 00 50 7B D3"});
}

TEST(RtuFramer, QuirkForms_NotRecognisedUnlessEnabled) {
  RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
  EXPECT_TRUE(frames_of(f, bytes("15 10 00 21 00 02 00 02 00 0D 84 85"), 0).empty());
  RtuFramer r(FrameShape::response, RtuTiming::for_serial(9600));
  r.expect_response(0x03, 2);
  EXPECT_TRUE(frames_of(r, bytes("01 03 00 04 00 68 00 50 C2 E7"), 0).empty());
}

TEST(RtuFramer, ExceptionResponse_IsFiveBytes) {
  RtuFramer f(FrameShape::response);
  EXPECT_EQ(frames_of(f, bytes("15 83 01 C0 F4 15 03 02 00 15 49 88")),
            (std::vector<std::string>{"15 83 01 C0 F4", "15 03 02 00 15 49 88"}));
}

TEST(RtuFramer, GapInsideAFrame_WithT15_DropsIt) {
  RtuTiming t = RtuTiming::for_serial(9600);  // t1.5 = 1718 us
  RtuFramer f(FrameShape::request, t);
  EXPECT_TRUE(frames_of(f, bytes("15 03 00 21"), 0).empty());
  EXPECT_TRUE(frames_of(f, bytes("00 04 17 17"), 3000).empty());  // gap > t1.5: invalid
  EXPECT_EQ(frames_of(f, bytes(kRead), 20'000), std::vector<std::string>{kRead});
}

TEST(RtuTiming, StandardValues) {
  EXPECT_EQ(RtuTiming::for_serial(9600, 11).t35_us, 4007U);  // 3.5 x 1146 us
  EXPECT_EQ(RtuTiming::for_serial(19200, 11).t15_us, 858U);
  EXPECT_EQ(RtuTiming::for_serial(115200).t35_us, 1750U);
  EXPECT_EQ(RtuTiming::for_serial(115200).t15_us, 750U);
}

TEST(RtuFramer, UnknownFunctionStream_WithoutTiming_NeverStalls) {
  // Found by fuzz_rtu_framer: bytes whose head has an unknown function code,
  // no timing to end them, more than a buffer's worth: the framer must keep
  // taking bytes and still find the good frame at the end.
  RtuFramer f(FrameShape::response);
  std::vector<uint8_t> in(600, 0x90);
  const auto good = bytes("15 03 02 00 15 49 88");
  in.insert(in.end(), good.begin(), good.end());
  EXPECT_EQ(frames_of(f, in), std::vector<std::string>{"15 03 02 00 15 49 88"});
}

TEST(RtuFramer, UnknownFunctionFrame_WithoutTiming_IsFoundByItsCrcOnceTheBufferFills) {
  RtuFramer f(FrameShape::request);
  std::vector<uint8_t> in = bytes("15 2B 0E 01 00 40 74");
  in.resize(in.size() + 300, 0x90);  // endless unknown bytes after it
  const auto got = frames_of(f, in);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got[0], "15 2B 0E 01 00 40 74");
}

// Issue 14, the last RTU framing gap: the byte count says one length, the
// frame has another, and its CRC holds over all its bytes. Once silence
// closes it, the framer hands it over whole (the slave answers 03, as over
// Modbus TCP); before silence it waits rather than dropping bytes.
TEST(RtuFramer, ByteCountDisagreeingWithTheLength_IsTakenWholeAtSilence) {
  const std::vector<std::vector<uint8_t>> cases = {
      with_crc({0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x03, 0x00, 0x07, 0x00, 0x08}),  // count 3, 4 bytes
      with_crc({0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x06, 0x00, 0x07, 0x00, 0x08}),  // count 6, 4 bytes
      with_crc({0x01, 0x0F, 0x00, 0x00, 0x00, 0x0A, 0x01, 0xFF, 0x03}),              // 10 coils, count 1
  };
  for (const auto& frame : cases) {
    RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
    EXPECT_TRUE(frames_of(f, frame, 0).empty()) << hex(frame);
    auto got = f.next(100'000);
    ASSERT_TRUE(got) << hex(frame);
    EXPECT_EQ(hex(got->adu), hex(frame));
    // And the slave engine answers 03.
    SlaveEngine engine;
    struct Bank : RegisterBank {
      Errc write_holding_registers(uint16_t, std::span<const uint16_t>) override { return Errc::ok; }
      Errc write_coils(uint16_t, uint16_t, std::span<const uint8_t>) override { return Errc::ok; }
    } bank;
    ASSERT_TRUE(engine.add_unit(UnitId{1}, bank).ok());
    std::array<uint8_t, kMaxRtuAduSize> out{};
    const auto h = engine.handle_rtu(got->adu, out);
    ASSERT_EQ(h.length, 5u) << hex(frame);
    EXPECT_EQ(out[1], frame[1] | 0x80);
    EXPECT_EQ(out[2], 0x03);
  }
}

// A frame whose CRC fails everywhere stays silent, and no suffix of it is
// taken for a frame.
TEST(RtuFramer, ByteCountDisagreeing_WithABadCrc_StaysSilent) {
  auto frame = with_crc({0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x03, 0x00, 0x07, 0x00, 0x08});
  frame.back() ^= 0x01;
  RtuFramer f(FrameShape::request, RtuTiming::for_serial(9600));
  EXPECT_TRUE(frames_of(f, frame, 0).empty());
  EXPECT_FALSE(f.next(100'000));
  EXPECT_EQ(f.buffered(), 0U);
  EXPECT_EQ(frames_of(f, bytes(kRead), 200'000), std::vector<std::string>{kRead});
}

// Each function's frames are found by their length, the moment their last
// byte arrives, long before the silence that would otherwise end them: the
// framer's predictions, one frame per request and response shape (a frame
// the framer could not predict would wait for t3.5 and fail here). FC08's
// return query data is the one request whose end is silence.
TEST(RtuFramer, EveryShapeIsFoundByItsLength_BeforeAnySilence) {
  const RtuTiming timing = RtuTiming::for_serial(9600);
  const auto framed_at_once = [&](FrameShape shape, std::vector<uint8_t> pdu) {
    RtuFramer f(shape, timing);
    pdu.insert(pdu.begin(), 0x11);
    const std::vector<uint8_t> frame = with_crc(pdu);
    std::vector<std::string> got = frames_of(f, frame, 1000);
    return got == std::vector<std::string>{hex(frame)};
  };
  const std::vector<std::vector<uint8_t>> requests = {
      {0x01, 0x00, 0x13, 0x00, 0x25},                    // read coils
      {0x03, 0x00, 0x6B, 0x00, 0x03},                    // read holding registers
      {0x05, 0x00, 0xAC, 0xFF, 0x00},                    // write single coil
      {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01},  // write multiple coils
      {0x10, 0x00, 0x01, 0x00, 0x01, 0x02, 0x00, 0x0A},  // write multiple registers
      {0x07},                                            // read exception status
      {0x0B},                                            // get comm event counter
      {0x0C},                                            // get comm event log
      {0x11},                                            // report server id
      {0x08, 0x00, 0x0A, 0x00, 0x00},                    // diagnostics: clear counters
      {0x2B, 0x0E, 0x01, 0x00},                          // read device identification
      {0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25},        // mask write register
      {0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00, 0x03, 0x06, 0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF},
  };
  for (const auto& pdu : requests)
    EXPECT_TRUE(framed_at_once(FrameShape::request, pdu)) << "request " << hex(pdu);
  EXPECT_FALSE(framed_at_once(FrameShape::request, {0x08, 0x00, 0x00, 0xA5, 0x37}))
      << "return query data echoes any data: silence ends it";
  const std::vector<std::vector<uint8_t>> responses = {
      {0x01, 0x02, 0xCD, 0x6B},                                      // read coils
      {0x03, 0x04, 0x02, 0x2B, 0x00, 0x00},                          // read holding registers
      {0x06, 0x00, 0x01, 0x00, 0x03},                                // write single register
      {0x10, 0x00, 0x01, 0x00, 0x02},                                // write multiple registers
      {0x07, 0x6D},                                                  // read exception status
      {0x0B, 0xFF, 0xFF, 0x01, 0x08},                                // get comm event counter
      {0x0C, 0x08, 0x00, 0x00, 0x01, 0x08, 0x01, 0x21, 0x20, 0x00},  // get comm event log
      {0x11, 0x02, 0x68, 0xFF},                                      // report server id
      {0x08, 0x00, 0x0A, 0x00, 0x00},                                // diagnostics: clear counters
      {0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25},                    // mask write register
      {0x17, 0x02, 0x00, 0xFE},                                      // read/write multiple registers
      {0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x01, 0x00, 0x03, 0x52, 0x54, 0x4B},  // one object
      {0x83, 0x02},                                                              // an exception
  };
  for (const auto& pdu : responses)
    EXPECT_TRUE(framed_at_once(FrameShape::response, pdu)) << "response " << hex(pdu);
}
