// CRC and PDU codec, from wire bytes typed from the seeds and the Modbus spec.
#include <gtest/gtest.h>

#include "rtukit/core.hpp"
#include "wire.hpp"

using namespace rtukit;
using test::bytes;
using test::hex;

namespace {

// Every example frame of the Inverjet seed, section 3, as printed.
const char* const kInverjetExamples[] = {
    "15 03 00 00 00 01 87 1E",                          // 3.2.1 read address
    "15 06 00 00 00 0C 8A DB",                          // 3.2.1 set address 12
    "15 03 00 01 00 01 D6 DE",                          // 3.2.2 read baud
    "15 06 00 01 00 03 9B 1F",                          // 3.2.2 set 9600
    "15 03 00 21 00 04 17 17",                          // 3.2.3.1 read state
    "15 06 00 22 00 01 EB 14",                          // 3.2.3.2 (1) and (3)
    "15 06 00 22 00 03 6A D5",                          // 3.2.3.2 (2)
    "15 10 00 21 00 02 00 00 00 01 25 40",              // 3.2.3.3 (1)
    "15 10 00 21 00 02 00 00 00 06 64 82",              // 3.2.3.3 (2)
    "15 10 00 21 00 02 00 01 00 0C B5 45",              // 3.2.3.3 (3)
    "15 10 00 21 00 02 00 02 00 0D 84 85",              // 3.2.3.3 (4)
    "15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F",  // 3.2.3.4 (1)
    "15 10 00 21 00 04 00 00 00 01 00 64 00 00 60 A7",  // 3.2.3.4 (2)
    "15 10 00 21 00 04 00 00 00 08 00 50 02 D0 FD 94",  // 3.2.3.4 (3)
    "15 10 00 21 00 04 00 01 00 08 00 32 00 00 4C 76",  // 3.2.3.4 (4)
    "15 10 00 21 00 04 00 01 00 08 00 32 02 D0 4C 8A",  // 3.2.3.4 (5)
};

// The same FC10 requests in the standard form (byte count present); CRCs
// computed with an independent implementation.
const char* const kInverjetFc10Standard[] = {
    "15 10 00 21 00 02 04 00 00 00 01 B0 4B",
    "15 10 00 21 00 02 04 00 00 00 06 F1 89",
    "15 10 00 21 00 02 04 00 01 00 0C 20 4E",
    "15 10 00 21 00 02 04 00 02 00 0D 11 8E",
    "15 10 00 21 00 04 08 00 00 00 06 00 50 07 08 55 EE",
    "15 10 00 21 00 04 08 00 00 00 01 00 64 00 00 A2 16",
    "15 10 00 21 00 04 08 00 00 00 08 00 50 02 D0 3F 25",
    "15 10 00 21 00 04 08 00 01 00 08 00 32 00 00 8E C7",
    "15 10 00 21 00 04 08 00 01 00 08 00 32 02 D0 8E 3B",
};

}  // namespace

TEST(Crc16, CheckValueOfTheCatalogue) {
  const std::string s = "123456789";
  EXPECT_EQ(crc16({reinterpret_cast<const uint8_t*>(s.data()), s.size()}), 0x4B37);
  EXPECT_EQ(crc16({}), 0xFFFF);
}

TEST(Crc16, EveryInverjetExampleFrameHasAValidCrc) {
  for (const char* f : kInverjetExamples) EXPECT_TRUE(rtu_crc_ok(bytes(f))) << f;
  for (const char* f : kInverjetFc10Standard) EXPECT_TRUE(rtu_crc_ok(bytes(f))) << f;
}

TEST(Crc16, ContinuesFromASeed) {
  const auto f = bytes("15 03 00 00 00 01");
  const uint16_t whole = crc16(f);
  const uint16_t parts = crc16(std::span(f).subspan(3), crc16(std::span(f).first(3)));
  EXPECT_EQ(whole, parts);
  EXPECT_EQ(whole, 0x1E87);  // sent as 87 1E
}

TEST(Crc16, RejectsShortAndCorruptFrames) {
  EXPECT_FALSE(rtu_crc_ok(bytes("15 03")));
  EXPECT_FALSE(rtu_crc_ok(bytes("15 03 00 00 00 01 87 1F")));
}

// The Inverjet document's FC10 form is accepted only where a device opts in.
constexpr FrameQuirks kInverjetQuirks{.fc10_without_byte_count = true};

TEST(Codec, InverjetExamplesDecodeAndReencodeByteForByte) {
  for (const char* text : kInverjetExamples) {
    const auto frame = bytes(text);
    const auto pdu = std::span<const uint8_t>(frame).subspan(1, frame.size() - 3);
    const Result<Request> r = decode_request(pdu, kInverjetQuirks);
    ASSERT_TRUE(r.ok()) << text << ": " << r.error().name();
    std::array<uint8_t, kMaxRtuAduSize> pdu_out{};
    const Result<size_t> n = encode_request(*r, pdu_out);
    ASSERT_TRUE(n.ok());
    std::array<uint8_t, kMaxRtuAduSize> adu{};
    const Result<size_t> m = rtu_encode(frame[0], {pdu_out.data(), *n}, adu);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(hex({adu.data(), *m}), text);
  }
}

TEST(Codec, InverjetFc10PrintedFormIsTheShortForm) {
  const auto frame = bytes("15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F");
  const Result<Request> r =
      decode_request(std::span<const uint8_t>(frame).subspan(1, frame.size() - 3), kInverjetQuirks);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->without_byte_count);
  EXPECT_EQ(r->address, 0x0021);
  EXPECT_EQ(r->quantity, 4);
  std::array<uint16_t, 4> regs{};
  load_registers(r->data, regs);
  EXPECT_EQ(regs, (std::array<uint16_t, 4>{0, 6, 80, 1800}));  // timer, initial, 80 %, 30:00
}

TEST(Codec, InverjetFc10StandardFormEncodesFromTheSameValues) {
  for (size_t i = 0; i < std::size(kInverjetFc10Standard); ++i) {
    const auto printed = bytes(kInverjetExamples[7 + i]);
    const Result<Request> r =
        decode_request(std::span<const uint8_t>(printed).subspan(1, printed.size() - 3), kInverjetQuirks);
    ASSERT_TRUE(r.ok());
    Request standard = *r;
    standard.without_byte_count = false;
    std::array<uint8_t, kMaxPduSize> pdu{};
    const Result<size_t> n = encode_request(standard, pdu);
    ASSERT_TRUE(n.ok());
    std::array<uint8_t, kMaxRtuAduSize> adu{};
    const Result<size_t> m = rtu_encode(0x15, {pdu.data(), *n}, adu);
    EXPECT_EQ(hex({adu.data(), *m}), kInverjetFc10Standard[i]);
    // And decoding the standard form gives the same request back.
    const auto std_frame = bytes(kInverjetFc10Standard[i]);
    const Result<Request> back =
        decode_request(std::span<const uint8_t>(std_frame).subspan(1, std_frame.size() - 3));
    ASSERT_TRUE(back.ok());
    EXPECT_FALSE(back->without_byte_count);
    EXPECT_EQ(hex(back->data), hex(r->data));
  }
}

TEST(Codec, ConvenienceEncodersMatchTheSeed) {
  std::array<uint8_t, kMaxPduSize> pdu{};
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  auto wrap = [&](Result<size_t> n) { return hex({adu.data(), *rtu_encode(0x15, {pdu.data(), *n}, adu)}); };
  EXPECT_EQ(wrap(encode_read_request(Function::read_holding_registers, 0x0021, 4, pdu)),
            "15 03 00 21 00 04 17 17");
  EXPECT_EQ(wrap(encode_write_single_register(0x0000, 0x000C, pdu)), "15 06 00 00 00 0C 8A DB");
  const uint16_t values[] = {0x0000, 0x0006, 0x0050, 0x0708};
  EXPECT_EQ(wrap(encode_write_multiple_registers(0x0021, values, pdu, false)),
            "15 10 00 21 00 04 00 00 00 06 00 50 07 08 97 5F");
  EXPECT_EQ(wrap(encode_write_multiple_registers(0x0021, values, pdu, true)),
            "15 10 00 21 00 04 08 00 00 00 06 00 50 07 08 55 EE");
}

TEST(Codec, QuantityLimitsGiveException03) {
  struct Case {
    const char* pdu;
    Errc expected;
  };
  const Case cases[] = {
      {"03 00 00 00 00", Errc::illegal_data_value},    // FC03 quantity 0
      {"03 00 00 00 7D", Errc::ok},                    // FC03 125
      {"03 00 00 00 7E", Errc::illegal_data_value},    // FC03 126
      {"04 00 00 00 7E", Errc::illegal_data_value},    // FC04 126
      {"01 00 00 07 D0", Errc::ok},                    // FC01 2000
      {"01 00 00 07 D1", Errc::illegal_data_value},    // FC01 2001
      {"02 00 00 00 00", Errc::illegal_data_value},    // FC02 0
      {"03 FF FF 00 02", Errc::illegal_data_address},  // past 0xFFFF
      {"03 FF FF 00 01", Errc::ok},                    // last register
      {"05 00 01 12 34", Errc::illegal_data_value},    // FC05 value not FF00/0000
      {"05 00 01 FF 00", Errc::ok},
      {"10 00 00 00 00 00", Errc::illegal_data_value},           // FC10 quantity 0
      {"10 00 00 00 01 03 00 01 02", Errc::illegal_data_value},  // byte count 3 for 1 register
      {"10 FF FF 00 02 04 00 01 00 02", Errc::illegal_data_address},
      {"0F 00 00 00 09 02 FF 01", Errc::ok},
      {"0F 00 00 00 09 01 FF", Errc::illegal_data_value},  // 9 coils need 2 bytes
      {"2B 0E 01 00", Errc::ok},                           // read device identification, basic
      {"2B 0E 05 00", Errc::illegal_data_value},           // read device id code 5
      {"2B 0D 01 00", Errc::illegal_function},             // MEI type 0D (CANopen): not implemented
      {"2B 0E 01", Errc::malformed},
      {"07", Errc::ok},
      {"07 00", Errc::illegal_data_value},
      {"08 00 01 00 00", Errc::ok},  // restart communications
      {"08 00 0B 00 00 00", Errc::illegal_data_value},
      {"08 00 00 01 02 03", Errc::ok},  // return query data: any data
      {"41", Errc::illegal_function},   // a user-defined function
      {"03 00 00", Errc::malformed},    // too short: dropped silently
  };
  for (const Case& c : cases) {
    const auto pdu = bytes(c.pdu);
    const Result<Request> r = decode_request(pdu);
    EXPECT_EQ(r.error().code(), c.expected) << c.pdu;
  }
}

TEST(Codec, Fc10QuantityLimitFromTheSpec) {
  for (uint16_t q : {uint16_t{0}, uint16_t{124}, uint16_t{126}}) {
    std::vector<uint8_t> pdu{0x10,
                             0x00,
                             0x00,
                             static_cast<uint8_t>(q >> 8),
                             static_cast<uint8_t>(q & 0xFF),
                             static_cast<uint8_t>((2 * q) & 0xFF)};
    pdu.resize(pdu.size() + 2 * q, 0);
    EXPECT_EQ(decode_request(pdu).error().code(), Errc::illegal_data_value) << q;
  }
  std::vector<uint8_t> max{0x10, 0x00, 0x00, 0x00, 123, 246};
  max.resize(max.size() + 246, 0);
  EXPECT_TRUE(decode_request(max).ok());
}

TEST(Codec, EncoderRefusesWhatTheProtocolCannotCarry) {
  std::array<uint8_t, kMaxPduSize> pdu{};
  EXPECT_EQ(encode_read_request(Function::read_holding_registers, 0, 126, pdu).error().code(),
            Errc::invalid_argument);
  EXPECT_EQ(encode_read_request(Function::write_single_register, 0, 1, pdu).error().code(),
            Errc::invalid_argument);
  std::vector<uint16_t> many(124, 0);
  EXPECT_EQ(encode_write_multiple_registers(0, many, pdu).error().code(), Errc::invalid_argument);
  std::array<uint8_t, 3> tiny{};
  EXPECT_EQ(encode_write_single_register(0, 1, tiny).error().code(), Errc::buffer_too_small);
}

TEST(Codec, ResponsesAreCheckedAgainstTheRequest) {
  Request read;
  read.function = 0x03;
  read.address = 0x0000;
  read.quantity = 1;
  const auto ok = bytes("03 02 00 15");
  const Result<Response> r = decode_response(read, ok);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(load_be16(r->data.data()), 0x15);

  EXPECT_EQ(decode_response(read, bytes("83 02")).error().code(), Errc::illegal_data_address);
  EXPECT_TRUE(decode_response(read, bytes("83 02")).error().is_exception());
  EXPECT_EQ(decode_response(read, bytes("04 02 00 15")).error().code(), Errc::unexpected_response);
  EXPECT_EQ(decode_response(read, bytes("03 04 00 15 00 00")).error().code(), Errc::unexpected_response);

  Request write;
  write.function = 0x06;
  write.address = 0x0022;
  write.value = 3;
  write.quantity = 1;
  EXPECT_TRUE(decode_response(write, bytes("06 00 22 00 03")).ok());
  EXPECT_EQ(decode_response(write, bytes("06 00 22 00 04")).error().code(), Errc::unexpected_response);
}

TEST(Codec, RehandTwoByteByteCountIsAcceptedByTheMaster) {
  Request read;
  read.function = 0x03;
  read.quantity = 2;
  const auto longer = bytes("03 00 04 00 68 00 50");  // the response views these bytes
  const Result<Response> r = decode_response(read, longer, FrameQuirks{.fc03_two_byte_count = true});
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->long_byte_count);
  EXPECT_EQ(load_be16(&r->data[0]), 0x68);
  EXPECT_EQ(load_be16(&r->data[2]), 0x50);
  const auto standard = bytes("03 04 00 68 00 50");
  const Result<Response> s = decode_response(read, standard);
  ASSERT_TRUE(s.ok());
  EXPECT_FALSE(s->long_byte_count);
}

TEST(Mbap, EncodesAndSizesAdus) {
  std::array<uint8_t, kMaxMbapAduSize> out{};
  const auto pdu = bytes("03 00 21 00 04");
  const Result<size_t> n = mbap_encode(0x0102, 0x15, pdu, out);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(hex({out.data(), *n}), "01 02 00 00 00 06 15 03 00 21 00 04");
  EXPECT_EQ(*mbap_adu_size({out.data(), 6}), 0U);  // need the whole header
  EXPECT_EQ(*mbap_adu_size({out.data(), *n}), 12U);
  EXPECT_EQ(mbap_adu_size(bytes("00 01 00 01 00 06 01")).error().code(), Errc::malformed);  // protocol 1
  EXPECT_EQ(mbap_adu_size(bytes("00 01 00 00 01 00 01")).error().code(), Errc::malformed);  // length 256
  const MbapHeader h = mbap_header({out.data(), *n});
  EXPECT_EQ(h.transaction, 0x0102);
  EXPECT_EQ(h.unit, 0x15);
}

TEST(Codec, QuirksAreOffByDefault) {
  // The short FC10 form is a byte-count mismatch to a standard decoder (03).
  const std::vector<uint8_t> short_fc10 = bytes("10 00 21 00 02 00 07 00 08");
  EXPECT_EQ(decode_request(short_fc10).error().code(), Errc::illegal_data_value);
  EXPECT_TRUE(decode_request(short_fc10, FrameQuirks{.fc10_without_byte_count = true}).ok());
  // A 2-byte byte count is not an answer to a standard master.
  Request read;
  read.function = 0x03;
  read.quantity = 2;
  const std::vector<uint8_t> longer = bytes("03 00 04 00 68 00 50");
  EXPECT_EQ(decode_response(read, longer).error().code(), Errc::unexpected_response);
}
