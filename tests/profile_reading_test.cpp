// The profile kit's reading (profile/reading.hpp, profile/typed_request.hpp):
// entries selected by key, read in as few requests as the layout allows, a
// failed request marking its entries, and the generic read's plan, request
// text and value text. A slave behind a MemoryLink on a ManualClock: no
// process, no port, no sleeping.
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/profile/reading.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/tool/typed_request.hpp"

namespace rtukit::profile {
namespace {

using namespace std::chrono_literals;
using namespace rtukit::tool;  // the typed requests (the generic commands' logic)

constexpr Named kModes[] = {{0, "normal"}, {1, "indoor"}};

constexpr Row kRows[] = {
    {.space = Space::holding, .address = 0x0010, .key = "speed", .title = "speed", .unit = "%"},
    {.space = Space::holding,
     .address = 0x0011,
     .key = "mode",
     .title = "mode",
     .encoding = Encoding::choice,
     .names = kModes},
    {.space = Space::holding,
     .address = 0x0012,
     .key = "temp",
     .title = "temperature",
     .encoding = Encoding::i16,
     .unit = "degC",
     .scale = 10},
    {.space = Space::input, .address = 0x0013, .key = "volts", .title = "volts", .role = Role::status},
    {.space = Space::holding,
     .address = 0x0014,
     .key = "energy",
     .title = "energy",
     .encoding = Encoding::u32},
    {.space = Space::holding, .address = 0x0100, .key = "seg", .title = "segment", .repeat = 4},
    {.space = Space::holding,
     .address = 0x0200,
     .key = "command",
     .title = "command",
     .role = Role::hold,
     .access = Access::write_only},
    {.space = Space::holding, .address = 0x0300, .key = "block", .title = "block", .repeat = 250},
    {.space = Space::holding, .address = 0x2000, .key = "far", .title = "past the slave's registers"},
};
constexpr Profile kProfile{.name = "testdev", .title = "a test device", .rows = kRows};

const Row& row(std::string_view key) {
  for (const Row& r : kRows)
    if (r.key == key) return r;
  throw std::out_of_range(std::string(key));
}

// A generic slave at unit 5 behind a MemoryLink on virtual time; every
// request it sees kept as (function, address, count).
struct Rig {
  struct Seen {
    uint8_t function;
    uint16_t address, count;
    bool operator==(const Seen&) const = default;
  };
  Rig() : bank(0x0400) {
    (void)engine.add_unit(UnitId{5}, bank);
    auto link = std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      seen.push_back({request[1], static_cast<uint16_t>(request[2] << 8 | request[3]),
                      static_cast<uint16_t>(request[4] << 8 | request[5])});
      if (silent) return MemoryLink::Reply{};
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(request, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 2ms};
    });
    master = std::make_unique<Master>(
        std::move(link), MasterOptions{.response_timeout = 100ms, .retries = 0, .clock = &clock});
  }
  ManualClock clock;
  MemoryBank bank;
  SlaveEngine engine;
  bool silent = false;
  std::vector<Seen> seen;
  std::unique_ptr<Master> master;
};

std::vector<std::string> names(const std::vector<Selected>& s) {
  std::vector<std::string> out;
  for (const Selected& e : s) out.push_back(entry_name(e));
  return out;
}

Outcome<std::vector<Selected>> select(std::vector<std::string> keys, bool for_write = false) {
  return select_rows(kProfile, keys, for_write);
}

// ------------------------------------------------------------- selection

TEST(ProfileReading, SelectsAKeyAnEntryOrAWholeBlock) {
  auto one = select({"temp"});
  ASSERT_TRUE(one.ok());
  ASSERT_EQ(one->size(), 1U);
  EXPECT_EQ((*one)[0].row, &row("temp"));
  EXPECT_EQ((*one)[0].index, 0U);

  auto entry = select({"seg[2]"});
  ASSERT_TRUE(entry.ok());
  ASSERT_EQ(entry->size(), 1U);
  EXPECT_EQ((*entry)[0].row, &row("seg"));
  EXPECT_EQ((*entry)[0].index, 2U);
  EXPECT_EQ(entry_name((*entry)[0]), "seg[2]");

  auto block = select({"seg", "speed"});
  ASSERT_TRUE(block.ok());
  EXPECT_EQ(names(*block), (std::vector<std::string>{"seg[0]", "seg[1]", "seg[2]", "seg[3]", "speed"}));
}

TEST(ProfileReading, NoKeysSelectEveryReadableEntry) {
  auto all = select({});
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->size(), 5U + 4 + 250 + 1);  // speed..energy, seg, block, far: not the write-only command
  for (const Selected& s : *all) EXPECT_NE(s.row->key, "command");
}

TEST(ProfileReading, AnUnknownKeyIsRefusedListingTheKnownOnes) {
  auto bad = select({"speed", "sped"});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code(), Errc::invalid_argument);
  EXPECT_EQ(bad.error().reason(),
            "no register 'sped' in testdev: did you mean 'speed'? (registers: speed, mode, temp, volts, "
            "energy, seg, "
            "command, block, far)");
  // Nothing near: no guess, the list only; a short key is never "near" a
  // different short one (one edit in three letters is another word).
  bad = select({"colour"});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().reason().find("did you mean"), std::string::npos) << bad.error().reason();
  bad = select({"sex"});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().reason().find("did you mean"), std::string::npos) << bad.error().reason();
  bad = select({"Volt"});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().reason().find("did you mean 'volts'?"), std::string::npos) << bad.error().reason();
}

TEST(ProfileReading, AWriteOnlyRowIsReadNever_WrittenYes) {
  auto read = select({"command"});
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code(), Errc::invalid_argument);
  EXPECT_EQ(read.error().reason(), "command is write-only");
  auto write = select({"command"}, true);
  ASSERT_TRUE(write.ok());
  EXPECT_EQ(names(*write), std::vector<std::string>{"command"});
}

TEST(ProfileReading, AnIndexPastTheBlockOrNotANumberIsRefused) {
  auto past = select({"seg[4]"});
  ASSERT_FALSE(past.ok());
  EXPECT_EQ(past.error().code(), Errc::invalid_argument);
  EXPECT_EQ(past.error().reason(), "seg has entries 0..3");
  auto nan = select({"seg[x]"});
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code(), Errc::invalid_argument);
  EXPECT_NE(nan.error().reason().find("index 'x'"), std::string_view::npos) << nan.error().reason();
}

// --------------------------------------------------------------- reading

TEST(ProfileReading, AdjacentEntriesGoInOneRequest_AGapStartsAnother) {
  Rig rig;
  rig.bank.holding[0x10] = 80;
  rig.bank.holding[0x11] = 1;
  rig.bank.holding[0x12] = 0xFFF6;  // -1.0 degC
  rig.bank.holding[0x14] = 0x0001;
  rig.bank.holding[0x15] = 0xE240;
  auto s = select({"speed", "mode", "temp", "energy"});
  ASSERT_TRUE(s.ok());
  const std::vector<ReadValue> v = read_selected(*rig.master, UnitId{5}, *s);
  ASSERT_EQ(v.size(), 4U);
  for (const ReadValue& e : v) EXPECT_TRUE(e.error.ok()) << entry_name(e.entry);
  EXPECT_EQ(v[0].raw, 80);
  EXPECT_EQ(v[1].raw, 1);
  EXPECT_EQ(v[2].raw, -10);
  EXPECT_EQ(v[3].raw, 123456);
  EXPECT_EQ(rig.master->stats().requests, 2U);
  EXPECT_EQ(rig.seen, (std::vector<Rig::Seen>{{0x03, 0x10, 3}, {0x03, 0x14, 2}}));
}

TEST(ProfileReading, ARequestCarriesAtMost125Registers) {
  Rig rig;
  for (uint16_t i = 0; i < 250; ++i) rig.bank.holding[0x300 + i] = i;
  auto s = select({"block"});
  ASSERT_TRUE(s.ok());
  const std::vector<ReadValue> v = read_selected(*rig.master, UnitId{5}, *s);
  ASSERT_EQ(v.size(), 250U);
  for (size_t i = 0; i < v.size(); ++i) {
    EXPECT_TRUE(v[i].error.ok()) << i;
    EXPECT_EQ(v[i].raw, static_cast<int64_t>(i));
  }
  EXPECT_EQ(rig.seen, (std::vector<Rig::Seen>{{0x03, 0x300, 125}, {0x03, 0x37D, 125}}));
}

TEST(ProfileReading, EntriesInTwoSpacesAreTwoRequests) {
  Rig rig;
  rig.bank.holding[0x12] = 7;
  rig.bank.input[0x13] = 230;
  auto s = select({"temp", "volts"});  // 0x12 then 0x13: adjacent, but holding and input
  ASSERT_TRUE(s.ok());
  const std::vector<ReadValue> v = read_selected(*rig.master, UnitId{5}, *s);
  ASSERT_EQ(v.size(), 2U);
  EXPECT_EQ(v[0].raw, 7);
  EXPECT_EQ(v[1].raw, 230);
  EXPECT_EQ(rig.seen, (std::vector<Rig::Seen>{{0x03, 0x12, 1}, {0x04, 0x13, 1}}));
}

TEST(ProfileReading, AFailedRequestMarksItsEntries_TheOthersAreRead) {
  Rig rig;
  rig.bank.holding[0x10] = 42;
  auto s = select({"speed", "far"});  // far is past the slave's registers: an exception
  ASSERT_TRUE(s.ok());
  const std::vector<ReadValue> v = read_selected(*rig.master, UnitId{5}, *s);
  ASSERT_EQ(v.size(), 2U);
  EXPECT_TRUE(v[0].error.ok());
  EXPECT_EQ(v[0].raw, 42);
  EXPECT_TRUE(v[1].error.is_exception());
  EXPECT_EQ(v[1].raw, 0);

  const ValuesJson j = values_json(v);
  EXPECT_FALSE(j.ok);
  EXPECT_EQ(j.values.dump(), nlohmann::ordered_json({{"speed", entry_json(row("speed"), 42)},
                                                     {"far", {{"error", std::string(v[1].error.text())}}}})
                                 .dump());
}

TEST(ProfileReading, ASilentDeviceMarksEveryEntry) {
  Rig rig;
  rig.silent = true;
  auto s = select({"speed", "mode", "volts"});
  ASSERT_TRUE(s.ok());
  const std::vector<ReadValue> v = read_selected(*rig.master, UnitId{5}, *s);
  ASSERT_EQ(v.size(), 3U);
  for (const ReadValue& e : v) EXPECT_EQ(e.error, Errc::timeout) << entry_name(e.entry);
  EXPECT_EQ(rig.seen.size(), 2U);
  EXPECT_FALSE(values_json(v).ok);
}

TEST(ProfileReading, ValuesJsonNamesBlockEntries_AllOkIsOk) {
  Rig rig;
  rig.bank.holding[0x101] = 9;
  auto s = select({"seg[1]", "temp"});
  ASSERT_TRUE(s.ok());
  const ValuesJson j = values_json(read_selected(*rig.master, UnitId{5}, *s));
  EXPECT_TRUE(j.ok);
  ASSERT_TRUE(j.values.contains("seg[1]"));
  EXPECT_EQ(j.values["seg[1]"]["raw"], 9);
  EXPECT_EQ(j.values.begin().key(), "seg[1]");
}

// --------------------------------------------------- typed reads: the plan

Outcome<ReadPlan> plan(ReadRequest r, std::string* note = nullptr) {
  return plan_read(r, note);
}

// A write by key: the row's rules before any port opens, then the one
// request the row's size asks for.
TEST(ProfileReading, AWriteByKeyIsCheckedAgainstItsRow_ThenSentAsOneRequest) {
  Outcome<KeyWrite> w = plan_key_write(kProfile, "temp", "-2.5");
  ASSERT_TRUE(w.ok()) << w.error().reason();
  EXPECT_EQ(w->raw, -25);
  Rig rig;
  ASSERT_FALSE(write_entry(*rig.master, UnitId{5}, *w));
  EXPECT_EQ(rig.bank.holding[0x0012], 0xFFE7);
  w = plan_key_write(kProfile, "energy", "70000");
  ASSERT_TRUE(w.ok());
  ASSERT_FALSE(write_entry(*rig.master, UnitId{5}, *w));
  EXPECT_EQ(rig.seen.back(), (Rig::Seen{0x10, 0x0014, 2}));
  w = plan_key_write(kProfile, "seg[2]", "7");
  ASSERT_TRUE(w.ok());
  ASSERT_FALSE(write_entry(*rig.master, UnitId{5}, *w));
  EXPECT_EQ(rig.seen.back(), (Rig::Seen{0x06, 0x0102, 7}));
  const size_t requests = rig.seen.size();
  struct Refusal {
    std::string key, value;
    Errc code;
    std::string says;
  };
  for (const Refusal& r : std::vector<Refusal>{
           {"seg", "1", Errc::invalid_argument, "seg is a block: name one entry, seg[i]"},
           {"volts", "1", Errc::invalid_argument, "volts is read-only"},
           {"command", "1", Errc::refused, "command is a hold command: use `rtukit testdev hold`"},
           {"mode", "fast", Errc::invalid_argument, "fast"},
           {"nothing", "1", Errc::invalid_argument, "no register 'nothing'"}}) {
    w = plan_key_write(kProfile, r.key, r.value);
    ASSERT_FALSE(w.ok()) << r.key;
    EXPECT_EQ(w.error().code(), r.code) << r.key;
    EXPECT_NE(w.error().reason().find(r.says), std::string_view::npos) << w.error().reason();
  }
  EXPECT_EQ(rig.seen.size(), requests);  // nothing refused was sent
}

TEST(TypedRequest, ABroadcastIsNotReadOnASerialLine_OnTcpUnit0IsAUnit) {
  auto serial = plan({.unit = UnitId{0}, .address = "0"});
  ASSERT_FALSE(serial.ok());
  EXPECT_EQ(serial.error().code(), Errc::invalid_argument);
  EXPECT_EQ(serial.error().reason(),
            "unit 0 is the broadcast address: nobody answers a broadcast, so it cannot be read (name a unit "
            "1..247)");
  EXPECT_TRUE(plan({.unit = UnitId{0}, .tcp = true, .address = "0"}).ok());
}

TEST(TypedRequest, OneTableOption_APrefixMayNotContradictIt) {
  auto two = plan({.tables_named = 2, .address = "0"});
  ASSERT_FALSE(two.ok());
  EXPECT_EQ(two.error().reason(), "choose one of --holding, --input, --coils, --discrete");

  std::string note;
  auto clash = plan({.tables_named = 1, .table = Space::holding, .address = "30001"}, &note);
  ASSERT_FALSE(clash.ok());
  EXPECT_EQ(clash.error().code(), Errc::invalid_argument);
  EXPECT_EQ(clash.error().reason(),
            "address 30001 names the input registers; drop the table option or the prefix");
  EXPECT_NE(note.find("30001 is taken as a reference"), std::string::npos) << note;  // shown even so

  auto prefix = plan({.address = "30001"});
  ASSERT_TRUE(prefix.ok());
  EXPECT_EQ(prefix->table, Space::input);
  EXPECT_EQ(prefix->address, 0);
  EXPECT_EQ(prefix->notation.kind, AddressNotation::Kind::reference);
}

TEST(TypedRequest, TheCountLimitIsPerValue_F32Is62) {
  EXPECT_TRUE(plan({.address = "0", .count = "62", .type = ValueType::f32}).ok());
  auto f32 = plan({.address = "0", .count = "63", .type = ValueType::f32});
  ASSERT_FALSE(f32.ok());
  EXPECT_EQ(f32.error().reason(), "count 63 is out of range 1..62");
  auto u16 = plan({.address = "0", .count = "126"});
  ASSERT_FALSE(u16.ok());
  EXPECT_EQ(u16.error().reason(), "count 126 is out of range 1..125");
  auto coils = plan({.tables_named = 1, .table = Space::coil, .address = "0", .count = "2000"});
  ASSERT_TRUE(coils.ok());
  EXPECT_TRUE(coils->bits);
  EXPECT_EQ(coils->count, 2000);
  EXPECT_FALSE(plan({.tables_named = 1, .table = Space::coil, .address = "0", .count = "2001"}).ok());
}

TEST(TypedRequest, AddressPlusCountStaysWithin0xFFFF) {
  EXPECT_TRUE(plan({.address = "65534", .count = "2"}).ok());
  auto over = plan({.address = "65535", .count = "2"});
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().reason(), "address + count passes 0xFFFF");
  EXPECT_TRUE(plan({.address = "65534", .type = ValueType::u32}).ok());
  EXPECT_FALSE(plan({.address = "65535", .type = ValueType::u32}).ok());
}

// --------------------------------------- typed reads: sent, decoded, shown

TEST(TypedRequest, ReadsDecodeByTypeAndWordOrder_TheContextNamesTheRequest) {
  Rig rig;
  rig.bank.input[0] = 0xE240;  // low word first: 123456
  rig.bank.input[1] = 0x0001;
  auto p = plan({.unit = UnitId{5},
                 .tables_named = 1,
                 .table = Space::input,
                 .address = "0",
                 .type = ValueType::u32,
                 .order = WordOrder::low_first});
  ASSERT_TRUE(p.ok());
  nlohmann::json values;
  ASSERT_TRUE(read_values(*rig.master, *p, values).ok());
  EXPECT_EQ(values.dump(), "[123456]");
  EXPECT_EQ(rig.seen, (std::vector<Rig::Seen>{{0x04, 0, 2}}));
  EXPECT_EQ(read_context(*p, *rig.master),
            "FC04 read input registers at 0 (0x0000) x2 from unit 5 on " + rig.master->describe());
  EXPECT_EQ(value_text(values[0], *p, true), "0x0001E240");
}

TEST(TypedRequest, HexShowsTheRawBits_F32AndBitsStayDecimal) {
  Rig rig;
  rig.bank.holding[3] = 0xFFFF;
  auto p = plan({.unit = UnitId{5}, .address = "3", .type = ValueType::i16});
  ASSERT_TRUE(p.ok());
  nlohmann::json values;
  ASSERT_TRUE(read_values(*rig.master, *p, values).ok());
  EXPECT_EQ(values.dump(), "[-1]");
  EXPECT_EQ(value_text(values[0], *p, true), "0xFFFF");
  EXPECT_EQ(value_text(values[0], *p, false), "-1");
  auto f = plan({.address = "0", .type = ValueType::f32});
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(value_text(nlohmann::json(1.5), *f, true), "1.5");
}

TEST(TypedRequest, AFailedReadLeavesNoValues) {
  Rig rig;
  rig.silent = true;
  auto p = plan({.unit = UnitId{5}, .address = "0", .count = "3"});
  ASSERT_TRUE(p.ok());
  nlohmann::json values = {1, 2};
  EXPECT_EQ(read_values(*rig.master, *p, values), Errc::timeout);
  EXPECT_TRUE(values.is_array());
  EXPECT_TRUE(values.empty());
}

TEST(TypedRequest, TablesAndAddressesAsJsonNameThem) {
  EXPECT_STREQ(table_name(Space::coil), "coils");
  EXPECT_STREQ(table_name(Space::discrete), "discrete");
  nlohmann::ordered_json plain, reference;
  put_address(plain, AddressNotation{}, 33);
  EXPECT_EQ(plain.dump(), R"({"address":33})");
  put_address(reference, AddressNotation{AddressNotation::Kind::reference, '4'}, 33);
  EXPECT_EQ(reference.dump(), R"({"address":34,"pdu_address":33})");
}

// ------------------------------------------------------- writes and FC17

TEST(TypedRequest, AWriteIsEncodedBeforeAnyPortOpens_OneValueIsASingleWrite) {
  const std::vector<std::string> one{"-1"}, f32{"1.5"};
  auto single = plan_write({.unit = UnitId{5}, .address = "40003", .values = one, .type = ValueType::i16});
  ASSERT_TRUE(single.ok());
  EXPECT_EQ(single->function, 0x06);
  EXPECT_EQ(single->address, 2);
  EXPECT_EQ(single->regs, std::vector<uint16_t>{0xFFFF});
  auto multiple = plan_write({.address = "2", .multiple = true, .values = one, .type = ValueType::i16});
  ASSERT_TRUE(multiple.ok());
  EXPECT_EQ(multiple->function, 0x10);
  auto two_words = plan_write({.address = "2", .values = f32, .type = ValueType::f32});
  ASSERT_TRUE(two_words.ok());
  EXPECT_EQ(two_words->function, 0x10);
  EXPECT_EQ(two_words->regs, (std::vector<uint16_t>{0x3FC0, 0x0000}));
  EXPECT_EQ(two_words->count, 2U);

  Rig rig;
  ASSERT_TRUE(send_write(*rig.master, *single).ok());
  EXPECT_EQ(rig.bank.holding[2], 0xFFFF);
  EXPECT_EQ(write_context(*single, *rig.master),
            "FC06 write single register at 40003 (0x0002) x1 to unit 5 on " + rig.master->describe());
}

// The confirmation names what was written, where and to whom; a broadcast
// on a serial line says that no unit answers it.
TEST(TypedRequest, AWriteSaysWhatItWroteInOneLine) {
  const std::vector<std::string> one{"1234"}, f32{"1.5"},
      many{"1", "2", "3", "4", "5", "6", "7", "8", "9", "10"}, mask{"0xFFF7", "0"};
  const WriteRequest single{.unit = UnitId{1}, .address = "0", .values = one};
  EXPECT_EQ(write_text(single, *plan_write(single), false),
            "wrote 1234 to holding register 0 (0x0000) of unit 1");
  const WriteRequest typed{.unit = UnitId{0}, .address = "2", .values = f32, .type = ValueType::f32};
  EXPECT_EQ(write_text(typed, *plan_write(typed), false),
            "wrote 1.5 (f32) to holding registers 2..3 (0x0002..0x0003) of every unit (a broadcast: no unit "
            "answers it)");
  EXPECT_TRUE(write_text(typed, *plan_write(typed), true).ends_with("of unit 0"));
  const WriteRequest list{.unit = UnitId{5}, .address = "0", .values = many};
  EXPECT_TRUE(
      write_text(list, *plan_write(list), false).starts_with("wrote 1, 2, 3, 4, ..., 10 (10 values) to"));
  const WriteRequest masked{.unit = UnitId{5}, .address = "40", .mask = mask};
  EXPECT_TRUE(write_text(masked, *plan_write(masked), false).starts_with("masked holding register 40"));
  EXPECT_TRUE(write_text(masked, *plan_write(masked), false).ends_with("of unit 5 with AND 0xFFF7 OR 0"));
}

TEST(TypedRequest, AWriteRefusesWhatItCannotWrite) {
  const std::vector<std::string> one{"1"}, two{"2"}, big{"40000"};
  auto coil = plan_write({.address = "00001", .values = one});
  ASSERT_FALSE(coil.ok());
  EXPECT_EQ(coil.error().code(), Errc::invalid_argument);
  EXPECT_EQ(coil.error().reason(), "address 00001 names a coil: add --coils to write coils");
  auto input = plan_write({.address = "30001", .values = one});
  ASSERT_FALSE(input.ok());
  EXPECT_EQ(input.error().reason(),
            "address 30001 names the input registers, which cannot be written (holding registers are 4xxxx)");
  auto range = plan_write({.address = "0", .values = big, .type = ValueType::i16});
  ASSERT_FALSE(range.ok());
  EXPECT_NE(range.error().reason().find("i16 value 40000 is out of range"), std::string_view::npos)
      << range.error().reason();
  auto bit = plan_write({.address = "0", .coils = true, .values = two});
  ASSERT_FALSE(bit.ok());
  EXPECT_NE(bit.error().reason().find("coil value 2"), std::string_view::npos) << bit.error().reason();
  const std::vector<std::string> many(124, "0");
  auto too_many = plan_write({.address = "0", .values = many});
  ASSERT_FALSE(too_many.ok());
  EXPECT_EQ(too_many.error().reason(), "at most 123 registers per write");
  const std::vector<std::string> pair{"1", "2"};
  auto over = plan_write({.address = "65535", .values = pair});
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().reason(), "address + count passes 0xFFFF");
  EXPECT_TRUE(plan_write({.address = "65534", .values = pair}).ok());
}

TEST(TypedRequest, CoilsAndMasksPickTheirFunctions) {
  const std::vector<std::string> one{"1"}, three{"1", "0", "1"}, mask{"0xFFF7", "0x0000"};
  auto coil = plan_write({.address = "7", .coils = true, .values = one});
  ASSERT_TRUE(coil.ok());
  EXPECT_EQ(coil->function, 0x05);
  EXPECT_EQ(coil->table, Space::coil);
  auto coils = plan_write({.unit = UnitId{5}, .address = "7", .coils = true, .values = three});
  ASSERT_TRUE(coils.ok());
  EXPECT_EQ(coils->function, 0x0F);
  EXPECT_EQ(coils->bits, (std::vector<uint8_t>{1, 0, 1}));
  auto masked = plan_write({.unit = UnitId{5}, .address = "4", .mask = mask});
  ASSERT_TRUE(masked.ok());
  EXPECT_EQ(masked->function, 0x16);
  EXPECT_EQ(masked->and_mask, 0xFFF7);
  EXPECT_EQ(masked->or_mask, 0);

  Rig rig;
  rig.bank.holding[4] = 0x000F;
  ASSERT_TRUE(send_write(*rig.master, *masked).ok());
  EXPECT_EQ(rig.bank.holding[4], 0x0007);
  ASSERT_TRUE(send_write(*rig.master, *coils).ok());
  EXPECT_EQ(rig.bank.coils[7], 1);
  EXPECT_EQ(rig.bank.coils[8], 0);
  EXPECT_EQ(rig.bank.coils[9], 1);
}

TEST(TypedRequest, Fc17RefusesTheBroadcastOtherTablesAndTooManyValues) {
  const std::vector<std::string> one{"7"};
  auto broadcast =
      plan_readwrite({.unit = UnitId{0}, .read_address = "0", .write_address = "0", .values = one});
  ASSERT_FALSE(broadcast.ok());
  EXPECT_EQ(broadcast.error().reason(), "FC17 reads: it cannot be broadcast (unit 0)");

  std::vector<std::string> notes;
  auto input = plan_readwrite({.read_address = "40001", .write_address = "30001", .values = one}, &notes);
  ASSERT_FALSE(input.ok());
  EXPECT_EQ(input.error().code(), Errc::invalid_argument);
  EXPECT_EQ(input.error().reason(),
            "30001 names the input registers: FC17 reads and writes holding registers");
  EXPECT_EQ(notes.size(), 2U);  // both addresses were references

  const std::vector<std::string> many(122, "0");
  auto too_many = plan_readwrite({.read_address = "0", .write_address = "0", .values = many});
  ASSERT_FALSE(too_many.ok());
  EXPECT_EQ(too_many.error().reason(), "at most 121 registers to write with FC17");
  auto over = plan_readwrite({.read_address = "65535", .count = 2, .write_address = "0", .values = one});
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().reason(), "address + count passes 0xFFFF");

  auto ok = plan_readwrite(
      {.unit = UnitId{5}, .read_address = "100", .count = 2, .write_address = "101", .values = one});
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(ok->values, std::vector<uint16_t>{7});
  Rig rig;
  EXPECT_EQ(
      readwrite_context(*ok, *rig.master),
      "FC17 read/write multiple registers: write 1 at 101 (0x0065), read 2 at 100 (0x0064) from unit 5 on " +
          rig.master->describe());
}

}  // namespace
}  // namespace rtukit::profile
