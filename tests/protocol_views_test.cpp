// Protocol facts and device-terms views that every front-end shares (issue
// 27: moved out of the CLI): the FC0C comm event bytes and the FC2B/0E
// object names (core), a sniffed transaction's timing forensics (driver) and
// the transaction in a device profile's terms, typed values of registers no
// row describes, addresses as typed (40001 notation), the generic slave's
// memory from a file (devices/profile).
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "rtukit/core/crc.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/devices/profile/schema.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/devices/profile/transaction_text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/driver/sniffer.hpp"
#include "rtukit/tool/address_notation.hpp"
#include "rtukit/tool/bank_file.hpp"
#include "rtukit/tool/protocol_text.hpp"
#include "sniffer_feed.hpp"

namespace rtukit {
namespace {

std::string event(uint8_t e) {
  return tool::comm_event_text(e);
}

TEST(ProtocolViews, CommEventBytesInWords) {
  EXPECT_EQ(event(comm_event::kRestart), "communications restart");
  EXPECT_EQ(event(comm_event::kEnteredListenOnly), "entered listen-only mode");
  EXPECT_EQ(event(0x80), "received");
  EXPECT_EQ(event(0xC0), "received broadcast");
  EXPECT_EQ(event(0x82), "received, communication error");
  EXPECT_EQ(event(0xF2), "received broadcast, communication error, character overrun, in listen-only mode");
  EXPECT_EQ(event(0x40), "sent");
  EXPECT_EQ(event(0x44), "sent, busy exception");
  // Every send bit at once: the longest text there is, and it fits.
  EXPECT_EQ(event(0x7F),
            "sent, read exception, server abort exception, busy exception, NAK exception, write timeout, "
            "in listen-only mode");
  EXPECT_EQ(event(0x05), "event 0x05");
  EXPECT_EQ(event(0x3A), "event 0x3A");
}

TEST(ProtocolViews, DeviceObjectNamesKeysAndConformity) {
  EXPECT_STREQ(tool::device_object_name(0), "vendor");
  EXPECT_STREQ(tool::device_object_name(1), "product code");
  EXPECT_STREQ(tool::device_object_name(3), "vendor URL");
  EXPECT_STREQ(tool::device_object_name(6), "application");
  EXPECT_EQ(tool::device_object_name(7), nullptr);
  EXPECT_EQ(tool::device_object_name(0x80), nullptr);
  EXPECT_STREQ(tool::device_object_key(1), "product_code");
  EXPECT_STREQ(tool::device_object_key(3), "vendor_url");
  EXPECT_EQ(tool::device_object_key(7), nullptr);
  EXPECT_STREQ(tool::conformity_level_name(0x01), "basic");
  EXPECT_STREQ(tool::conformity_level_name(0x82), "regular");  // bit 7: individual access too
  EXPECT_STREQ(tool::conformity_level_name(0x83), "extended");
  EXPECT_STREQ(tool::conformity_level_name(0x04), "unknown");
}

std::vector<uint8_t> with_crc(std::vector<uint8_t> b) {
  const uint16_t crc = crc16(b);
  b.push_back(static_cast<uint8_t>(crc & 0xFF));
  b.push_back(static_cast<uint8_t>(crc >> 8));
  return b;
}

SniffedFrame frame(const std::vector<uint8_t>& bytes) {
  SniffedFrame f;
  f.bytes = with_crc(bytes);
  f.crc_ok = true;
  return f;
}

SniffedTransaction exchange(const std::vector<uint8_t>& request, const std::vector<uint8_t>& response) {
  SniffedTransaction t;
  t.request = frame(request);
  if (!response.empty()) t.response = frame(response);
  return t;
}

using test::kChar;
using test::send;

TEST(ProtocolViews, SnifferForensicsInWords) {
  Sniffer s({.baud = 9600, .bits_per_char = 10});  // t1.5 1.56 ms, t3.5 3.64 ms
  const std::vector<uint8_t> request = with_crc({0x15, 0x03, 0x00, 0x21, 0x00, 0x04});
  const std::vector<uint8_t> response = with_crc({0x15, 0x03, 0x08, 0, 0, 0, 8, 0, 80, 0x07, 0x08});
  uint64_t t = send(s, request, 0);
  t = send(s, response, t);  // no silence at all
  t = send(s, request, t + 20000);
  t = send(s, response, t + 1000);           // 1 ms of silence
  t = send(s, request, t + 20000, 3, 2000);  // 2 ms between two characters of the request
  t = send(s, response, t + 4000);
  t = send(s, request, t + 20000, 4, 6000);  // a silence longer than t3.5 inside the request
  t = send(s, response, t + 4000);
  t = send(s, request, t + 20000);
  t = send(s, response, t + 4000);  // by the rules
  s.flush(t + 2'000'000);
  const std::vector<SniffedTransaction> got = s.take();
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(s.forensics(got[0]), std::vector<std::string>{"response glued to the frame before"});
  EXPECT_EQ(s.forensics(got[1]),
            std::vector<std::string>{"response after 1.00 ms of silence (< t3.5 3.64 ms)"});
  EXPECT_EQ(s.forensics(got[2]), std::vector<std::string>{"request gap 2.00 ms inside (> t1.5 1.56 ms)"});
  EXPECT_EQ(s.forensics(got[3]), std::vector<std::string>{"request split by a silence > t3.5"});
  EXPECT_TRUE(s.forensics(got[4]).empty());
}

namespace profile_rows {
using namespace profile;
constexpr Named kModes[] = {{0, "normal"}, {1, "indoor"}, {3, "outdoor"}};
constexpr Row kRows[] = {
    {.space = Space::holding,
     .address = 0x0010,
     .key = "speed",
     .title = "speed",
     .role = Role::control,
     .unit = "%",
     .range = {0, 100}},
    {.space = Space::holding,
     .address = 0x0011,
     .key = "mode",
     .title = "mode",
     .encoding = Encoding::choice,
     .names = kModes},
    {.space = Space::holding,
     .address = 0x0014,
     .key = "total",
     .title = "total",
     .encoding = Encoding::u32,
     .unit = "kWh",
     .scale = 100,
     .order = WordOrder::low_first},
    {.space = Space::holding,
     .address = 0x0100,
     .key = "seg_end",
     .title = "segment end",
     .encoding = Encoding::duration,
     .unit = "s",
     .range = {0, 5999},
     .repeat = 4},
    {.space = Space::input,
     .address = 0x0000,
     .key = "temperature",
     .title = "temperature",
     .encoding = Encoding::i16,
     .unit = "degC",
     .scale = 10},
};
constexpr Profile kProfile{.name = "testdev", .title = "a test device", .rows = kRows};
}  // namespace profile_rows

TEST(ProtocolViews, NamedValuesByTheProfilesRows) {
  using profile_rows::kProfile;
  const uint16_t holding[] = {80, 3, 0x0000, 0x3039, 0x0000};
  // 0x0012..0x0013 belong to no row; total is 0x3039 low first = 123.45 kWh.
  EXPECT_EQ(profile::named_values(kProfile, profile::Space::holding, 0x0010, holding),
            "speed = 80 %, mode = outdoor (3), 0x0012 = 0, 0x0013 = 12345, 0x0014 = 0");
  const uint16_t total[] = {0x3039, 0x0000};
  EXPECT_EQ(profile::named_values(kProfile, profile::Space::holding, 0x0014, total), "total = 123.45 kWh");
  const uint16_t segments[] = {1800, 90};
  EXPECT_EQ(profile::named_values(kProfile, profile::Space::holding, 0x0101, segments),
            "seg_end[1] = 30:00, seg_end[2] = 01:30");
  const uint16_t temperature[] = {static_cast<uint16_t>(-55)};
  EXPECT_EQ(profile::named_values(kProfile, profile::Space::input, 0x0000, temperature),
            "temperature = -5.5 degC");
}

TEST(ProtocolViews, SpaceOfFunction) {
  using profile::Space;
  EXPECT_EQ(profile::space_of_function(0x01), Space::coil);
  EXPECT_EQ(profile::space_of_function(0x0F), Space::coil);
  EXPECT_EQ(profile::space_of_function(0x02), Space::discrete);
  EXPECT_EQ(profile::space_of_function(0x03), Space::holding);
  EXPECT_EQ(profile::space_of_function(0x04), Space::input);
  EXPECT_EQ(profile::space_of_function(0x10), Space::holding);
}

TEST(ProtocolViews, TransactionsInDeviceTerms) {
  const profile::UnitProfiles units{{21, &profile_rows::kProfile}};
  // A unit with a profile: its registers by name, reads and writes.
  EXPECT_EQ(
      profile::transaction_text(
          exchange({21, 0x03, 0x00, 0x10, 0x00, 0x02}, {21, 0x03, 0x04, 0x00, 0x50, 0x00, 0x01}), units),
      " 21 read holding 0x0010 x2: speed = 80 %, mode = indoor (1)");
  EXPECT_EQ(
      profile::transaction_text(exchange({21, 0x10, 0x00, 0x10, 0x00, 0x02, 0x04, 0x00, 0x32, 0x00, 0x00},
                                         {21, 0x10, 0x00, 0x10, 0x00, 0x02}),
                                units),
      " 21 write speed = 50 %, mode = normal (0): ok");
  EXPECT_EQ(profile::transaction_text(exchange({21, 0x06, 0x00, 0x10, 0x00, 0x78}, {21, 0x86, 0x03}), units),
            " 21 write speed = 120 % -> exception 03 (illegal data value)");
  // The Rehand 6600's FC03 answer with a 2-byte count.
  EXPECT_EQ(profile::transaction_text(
                exchange({21, 0x04, 0x00, 0x00, 0x00, 0x01}, {21, 0x04, 0x00, 0x02, 0x00, 0xFA}), units),
            " 21 read input 0x0000 x1: temperature = 25.0 degC");
  // A unit with none: Modbus terms.
  EXPECT_EQ(profile::transaction_text(
                exchange({5, 0x03, 0x00, 0x10, 0x00, 0x02}, {5, 0x03, 0x04, 0, 80, 0, 1}), units),
            "  5 read holding 0x0010 x2: 80 1");
  EXPECT_EQ(
      profile::transaction_text(exchange({5, 0x01, 0x00, 0x00, 0x00, 0x03}, {5, 0x01, 0x01, 0x05}), units),
      "  5 read coil 0x0000 x3: 101");
  EXPECT_EQ(profile::transaction_text(
                exchange({5, 0x05, 0x00, 0x07, 0xFF, 0x00}, {5, 0x05, 0x00, 0x07, 0xFF, 0x00}), units),
            "  5 write coil 7 = on: ok");
  EXPECT_EQ(profile::transaction_text(exchange({0, 0x06, 0x00, 0x10, 0x00, 0x01}, {}), units),
            "all write 0x0010 = 1 (broadcast)");
  EXPECT_EQ(profile::transaction_text(exchange({7, 0x04, 0x00, 0x00, 0x00, 0x01}, {}), units),
            "  7 read input 0x0000 x1 -> no response");
  SniffedTransaction damaged = exchange({7, 0x03, 0x00, 0x00, 0x00, 0x01}, {7, 0x03, 0x02, 0x00, 0x01});
  damaged.response->crc_ok = false;
  damaged.response->bytes.back() ^= 0xFF;
  EXPECT_EQ(profile::transaction_text(damaged, units).substr(0, 44),
            "  7 read holding 0x0000 x1 -> CRC error (07 ");
  // A function rtukit does not decode: its bytes.
  EXPECT_EQ(profile::transaction_text(exchange({7, 0x41, 0x01, 0x02}, {7, 0xC1, 0x01}), units),
            "  7 FC41 41 01 02 -> exception 01 (illegal function)");
  SniffedTransaction garbage;
  garbage.response = SniffedFrame{.bytes = {0x01, 0x02, 0x03}};
  EXPECT_EQ(profile::transaction_text(garbage, units), "garbage (3 bytes: 01 02 03)");
  // Functions without a register range are named, not shown as "read holding 0x0000 x0".
  EXPECT_EQ(profile::transaction_text(
                exchange({9, 0x08, 0x00, 0x00, 0x12, 0x34}, {9, 0x08, 0x00, 0x00, 0x12, 0x34}), units),
            "  9 diagnostics, sub-function 0x0000: ok");
  EXPECT_EQ(profile::transaction_text(exchange({9, 0x11}, {9, 0x11, 0x02, 0x01, 0xFF}), units),
            "  9 report server id: ok");
  EXPECT_EQ(profile::transaction_text(exchange({9, 0x2B, 0x0E, 0x01, 0x00}, {9, 0xAB, 0x01}), units),
            "  9 read device identification, code 1, object 0x00 -> exception 01 (illegal function)");
  EXPECT_EQ(profile::transaction_text(exchange({9, 0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25},
                                               {9, 0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25}),
                                      units),
            "  9 mask write 0x0004 AND 0x00F2 OR 0x0025: ok");
}

TEST(ProtocolViews, NumbersAsTyped) {
  EXPECT_EQ(*profile::parse_number("33", "address", 0, 0xFFFF), 33);
  EXPECT_EQ(*profile::parse_number("0x21", "address", 0, 0xFFFF), 0x21);
  EXPECT_EQ(*profile::parse_number("-5", "offset", -10, 10), -5);
  const Outcome<int64_t> word = profile::parse_number("x1", "address", 0, 0xFFFF);
  EXPECT_EQ(word.error().code(), Errc::invalid_argument);
  EXPECT_EQ(word.error().reason(), "address 'x1' is not a number (decimal, or hex as 0x21)");
  EXPECT_EQ(profile::parse_number("300", "count", 1, 125).error().reason(),
            "count 300 is out of range 1..125");
}

TEST(ProtocolViews, TypedValuesFromRegisters) {
  using profile::ValueType;
  using profile::WordOrder;
  const auto decode = [](ValueType t, std::vector<uint16_t> words, WordOrder o = WordOrder::high_first) {
    return profile::decode_typed(t, words, o);
  };
  EXPECT_EQ(profile::value_type("f32"), ValueType::f32);
  EXPECT_EQ(profile::value_type("f64"), std::nullopt);
  EXPECT_EQ(profile::words_of(ValueType::i16), 1u);
  EXPECT_EQ(profile::words_of(ValueType::f32), 2u);
  EXPECT_EQ(decode(ValueType::u16, {0xFFFF}).dump(), "65535");
  EXPECT_EQ(decode(ValueType::i16, {0xFFFF}).dump(), "-1");
  EXPECT_EQ(decode(ValueType::u32, {0x0001, 0x0002}).dump(), "65538");
  EXPECT_EQ(decode(ValueType::u32, {0x0001, 0x0002}, WordOrder::low_first).dump(), "131073");
  EXPECT_EQ(decode(ValueType::i32, {0xFFFF, 0xFFFE}).dump(), "-2");
  EXPECT_EQ(decode(ValueType::f32, {0x3FC0, 0x0000}).dump(), "1.5");
  EXPECT_EQ(decode(ValueType::f32, {0x0000, 0x3FC0}, WordOrder::low_first).dump(), "1.5");
  EXPECT_EQ(decode(ValueType::f32, {0xC148, 0x0000}).get<double>(), -12.5);
}

TEST(ProtocolViews, TypedValuesToRegisters) {
  using profile::ValueType;
  using profile::WordOrder;
  const auto encode = [](ValueType t, std::string_view text, WordOrder o = WordOrder::high_first) {
    std::vector<uint16_t> out;
    const Status e = profile::encode_typed(t, text, o, out);
    return e.ok() ? out : std::vector<uint16_t>{};
  };
  const auto refusal = [](ValueType t, std::string_view text) {
    std::vector<uint16_t> out;
    const Status e = profile::encode_typed(t, text, WordOrder::high_first, out);
    EXPECT_TRUE(out.empty());
    return e.code() == Errc::invalid_argument ? std::string(e.reason()) : std::string("accepted");
  };
  EXPECT_EQ(encode(ValueType::u16, "1234"), (std::vector<uint16_t>{1234}));
  EXPECT_EQ(encode(ValueType::i16, "-1"), (std::vector<uint16_t>{0xFFFF}));
  EXPECT_EQ(encode(ValueType::i16, "0xFFFF"), (std::vector<uint16_t>{0xFFFF}));  // hex: the raw bits
  EXPECT_EQ(encode(ValueType::i32, "-2"), (std::vector<uint16_t>{0xFFFF, 0xFFFE}));
  EXPECT_EQ(encode(ValueType::i32, "-2", WordOrder::low_first), (std::vector<uint16_t>{0xFFFE, 0xFFFF}));
  EXPECT_EQ(encode(ValueType::u32, "0x12345678"), (std::vector<uint16_t>{0x1234, 0x5678}));
  EXPECT_EQ(encode(ValueType::f32, "1.5"), (std::vector<uint16_t>{0x3FC0, 0x0000}));
  EXPECT_EQ(encode(ValueType::f32, "-12.5", WordOrder::low_first), (std::vector<uint16_t>{0x0000, 0xC148}));
  EXPECT_EQ(refusal(ValueType::i16, "40000"),
            "i16 value 40000 is out of range -32768..32767 (or 0x0000..0xFFFF in hex, the raw bits)");
  EXPECT_EQ(refusal(ValueType::u16, "70000"), "u16 value 70000 is out of range 0..65535");
  EXPECT_EQ(refusal(ValueType::u32, "-1"), "u32 value -1 is out of range 0..4294967295");
  EXPECT_EQ(refusal(ValueType::f32, "1.5x"), "value '1.5x' is not a number");
  EXPECT_EQ(refusal(ValueType::f32, "nan"), "f32 value nan is not a finite number");
  EXPECT_EQ(refusal(ValueType::f32, "1e50"),
            "f32 value 1e50 is out of range (at most 3.4028235e+38 either side of 0)");
  EXPECT_EQ(refusal(ValueType::f32, "1e-50"),
            "f32 value 1e-50 is too small for f32: it would be written as 0");
}

TEST(ProtocolViews, AGenericSlavesMemoryFromAFile) {
  MemoryBank bank(100);
  const Status ok = tool::load_bank_text("init.json", R"({
      "holding": {"0x21": [1, 2, -1], "0": 5},
      "input": {"3": 7},
      "coils": {"10": [1, 0, 1]},
      "identification": {"vendor": "ACME", "product_code": "M-3", "vendor_url": "https://acme.example", "0x80": "serial 42"}})",
                                         bank);
  ASSERT_TRUE(ok.ok()) << ok.reason();
  EXPECT_EQ(bank.holding[0], 5);
  EXPECT_EQ(bank.holding[0x21], 1);
  EXPECT_EQ(bank.holding[0x22], 2);
  EXPECT_EQ(bank.holding[0x23], 0xFFFF);
  EXPECT_EQ(bank.input[3], 7);
  EXPECT_EQ(bank.coils[10], 1);
  EXPECT_EQ(bank.coils[11], 0);
  EXPECT_EQ(bank.coils[12], 1);
  EXPECT_EQ(bank.objects[0], "ACME");
  EXPECT_EQ(bank.objects[1], "M-3");
  EXPECT_EQ(bank.objects[2], "1.0");  // not in the file: the bank's own
  EXPECT_EQ(bank.objects[3], "https://acme.example");
  EXPECT_EQ(bank.objects[0x80], "serial 42");

  const auto refusal = [](std::string_view text) {
    MemoryBank b(100);
    const Status e = tool::load_bank_text("init.json", text, b);
    return e.code() == Errc::invalid_argument ? std::string(e.reason()) : std::string("accepted");
  };
  EXPECT_EQ(refusal(R"({"holding": {"99": [1, 2]}})"), "init.json: holding address 100 past --registers");
  EXPECT_EQ(refusal(R"({"coils": {"0": 2}})"), "init.json: coils value 2 out of range");
  EXPECT_EQ(refusal(R"({"holding": {"0": 70000}})"), "init.json: holding value 70000 out of range");
  EXPECT_EQ(refusal(R"({"holding": {"0": 1.5}})"), "init.json: holding[0] is not an integer");
  EXPECT_EQ(refusal(R"({"holding": {"x": 1}})"), "address 'x' is not a number (decimal, or hex as 0x21)");
  EXPECT_EQ(refusal(R"({"registers": {"0": 1}})"),
            "init.json: unknown table 'registers' (holding, input, coils, discrete)");
  EXPECT_EQ(refusal(R"({"identification": {"vendor": ""}})"),
            "init.json: identification 'vendor' must be text of 1..244 characters");
  EXPECT_EQ(refusal(R"({"identification": {"serial": "1"}})"),
            "object id 'serial' is not a number (decimal, or hex as 0x21)");
  EXPECT_EQ(refusal("[1, 2]"), "init.json: expected an object of tables");
  EXPECT_EQ(refusal("{").substr(0, 30), "init.json: not valid JSON: [js");
  const Status missing = tool::load_bank_file("/nonexistent/init.json", *std::make_unique<MemoryBank>(1));
  EXPECT_EQ(missing.code(), Errc::io_error);
  EXPECT_EQ(missing.reason().substr(0, 40), "cannot read /nonexistent/init.json: No s");
}

TEST(ProtocolViews, AddressesAsTypedAndShownBack) {
  using profile::Space;
  const Outcome<tool::TypedAddress> plain = tool::parse_address("0x21", false);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->address, 0x21);
  EXPECT_EQ(plain->space, std::nullopt);
  EXPECT_EQ(plain->notation.where(plain->address), "33 (0x0021)");
  EXPECT_TRUE(plain->note.empty());

  const Outcome<tool::TypedAddress> one = tool::parse_address("34", true);
  EXPECT_EQ(one->address, 33);
  EXPECT_EQ(one->notation.span(33, 2), "34..35 (0x0021..0x0022)");

  const Outcome<tool::TypedAddress> ref = tool::parse_address("40034", false);
  ASSERT_TRUE(ref.ok());
  EXPECT_EQ(ref->address, 33);
  EXPECT_EQ(ref->space, Space::holding);
  EXPECT_EQ(ref->notation.where(33), "40034 (0x0021)");
  EXPECT_EQ(ref->notation.span(9998, 2), "49999..410000 (0x270E..0x270F)");
  EXPECT_EQ(
      ref->note,
      "40034 is taken as a reference: holding register 34 (0-based 33; for address 40034 write 0x9C62)");
  const Outcome<tool::TypedAddress> coil = tool::parse_address("000010", false);
  EXPECT_EQ(coil->space, Space::coil);
  EXPECT_EQ(coil->address, 9);
  EXPECT_EQ(coil->notation.text(9), "000010");
  EXPECT_EQ(tool::parse_address("10001", false)->space, Space::discrete);
  EXPECT_EQ(tool::parse_address("30001", false)->space, Space::input);

  EXPECT_EQ(tool::parse_address("40000", false).error().reason(),
            "40000 is not a reference: holding registers are 40001..49999 (six digits: 400001..465536); for "
            "address 40000 write 0x9C40");
  EXPECT_EQ(tool::parse_address("70000", false).error().reason(), "address 70000 is out of range 0..65535");
  EXPECT_EQ(tool::parse_address("0", true).error().reason(), "address (1-based) 0 is out of range 1..65536");
  EXPECT_EQ(tool::space_noun(Space::input, false), "input register");
  EXPECT_EQ(tool::space_noun(Space::discrete, true), "discrete inputs");
}

TEST(ProtocolViews, HexPairs) {
  const uint8_t bytes[] = {0x15, 0x03, 0x00, 0x21};
  EXPECT_EQ(profile::hex(bytes), "15 03 00 21");
  EXPECT_EQ(profile::hex({}), "");
}

}  // namespace
}  // namespace rtukit
