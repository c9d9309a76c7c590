// The device profile kit: the register map (lookup, strict checks, words <->
// values), the Image, the generic Model, values as text, the state file and
// register-map files (line-numbered errors, export -> load round trip).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "process.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/devices/profile/map_file.hpp"
#include "rtukit/devices/profile/model.hpp"
#include "rtukit/devices/profile/state_file.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::profile {
namespace {

constexpr Named kModes[] = {{0, "normal"}, {1, "indoor"}, {3, "outdoor"}};
constexpr Named kBits[] = {{0, "over-voltage"}, {2, "over-current"}};
constexpr Flags kMasked = 1U << 1;
constexpr FlagName kFlagNames[] = {{kPersisted, "persisted"}, {kMasked, "masked"}};

constexpr Row kRows[] = {
    {.space = Space::holding,
     .address = 0x0010,
     .key = "speed",
     .title = "speed",
     .role = Role::control,
     .unit = "%",
     .range = {0, 100},
     .default_value = 50,
     .flags = kPersisted | kMasked},
    {.space = Space::holding,
     .address = 0x0011,
     .key = "mode",
     .title = "mode",
     .encoding = Encoding::choice,
     .names = kModes},
    {.space = Space::holding,
     .address = 0x0012,
     .key = "limit",
     .title = "limit",
     .encoding = Encoding::i16,
     .unit = "degC",
     .scale = 10,
     .range = {-400, 1000},
     .writable_range = {0, 800},
     .default_value = 250},
    {.space = Space::holding,
     .address = 0x0014,
     .key = "total",
     .title = "total",
     .encoding = Encoding::u32,
     .unit = "kWh",
     .scale = 100,
     .order = WordOrder::low_first,
     .flags = kPersisted},
    {.space = Space::holding,
     .address = 0x0100,
     .key = "seg_speed",
     .title = "segment speed",
     .range = {0, 100},
     .default_value = 0,
     .default_first = 20,
     .flags = kPersisted,
     .repeat = 4,
     .stride = 2},
    {.space = Space::holding,
     .address = 0x0101,
     .key = "seg_end",
     .title = "segment end",
     .encoding = Encoding::duration,
     .unit = "s",
     .range = {0, 5999},
     .flags = kPersisted,
     .repeat = 4,
     .stride = 2},
    {.space = Space::holding,
     .address = 0x0200,
     .key = "command",
     .title = "command",
     .role = Role::hold,
     .access = Access::write_only,
     .range = {0, 1}},
    {.space = Space::input,
     .address = 0x0000,
     .key = "version",
     .title = "version",
     .encoding = Encoding::version,
     .default_value = 0x00010002},
    {.space = Space::input,
     .address = 0x0002,
     .key = "alarms",
     .title = "alarms",
     .encoding = Encoding::bits,
     .names = kBits},
    {.space = Space::coil,
     .address = 0x0000,
     .key = "relay",
     .title = "relay",
     .role = Role::control,
     .encoding = Encoding::boolean},
};
constexpr Profile kProfile{
    .name = "testdev", .title = "a test device", .rows = kRows, .flag_names = kFlagNames};
constexpr RegisterMap kMap{kRows};

// Compile-time handles: a typo here would not compile.
constexpr Handle kSpeed = kMap.handle("speed");
constexpr Handle kTotal = kMap.handle("total");
static_assert(kMap.row(kSpeed).address == 0x0010);
static_assert(kMap.image_size() == 1 + 1 + 1 + 2 + 4 + 4 + 1 + 2 + 1 + 1);
static_assert(kMap.at(Space::holding, 0x0102).row == &kRows[4] && kMap.at(Space::holding, 0x0102).index == 1);
static_assert(kMap.at(Space::holding, 0x0103).row == &kRows[5]);
static_assert(!kMap.at(Space::holding, 0x0013));

class TestModel final : private ImageStorage<kMap.image_size()>, public Model {
 public:
  TestModel() : Model(kProfile, words) {}
  int applied = 0;

 protected:
  Error apply_write(Space space, uint16_t address, std::span<const uint16_t> values) noexcept override {
    // A device rule: speed may not be written while the relay is on (04).
    if (space == Space::holding && address <= 0x0010 && address + values.size() > 0x0010 &&
        image().get(kMap.handle("relay")) != 0)
      return Error(Errc::server_device_failure, "relay on");
    ++applied;
    return Model::apply_write(space, address, values);
  }
};

TEST(ProfileMap, Lookups) {
  EXPECT_EQ(kMap.find("mode"), &kRows[1]);
  EXPECT_EQ(kMap.find("nope"), nullptr);
  EXPECT_EQ(find_row(kMap, "SEG-SPEED"), &kRows[4]);  // either case style
  const Slot total_low = kMap.at(Space::holding, 0x0015);
  EXPECT_EQ(total_low.row, &kRows[3]);
  EXPECT_EQ(total_low.word, 1);
  EXPECT_FALSE(kMap.at(Space::input, 0x0010));
}

TEST(ProfileMap, StrictReadsAndWrites) {
  EXPECT_TRUE(kMap.check_read(Space::holding, 0x0010, 3).ok());
  EXPECT_EQ(kMap.check_read(Space::holding, 0x0010, 4).code(),
            Errc::illegal_data_address);  // 0x0013 is a gap
  EXPECT_EQ(kMap.check_read(Space::holding, 0x0200, 1).code(), Errc::illegal_data_address);  // write-only
  EXPECT_TRUE(kMap.check_write(Space::holding, 0x0200, std::array<uint16_t, 1>{1}).ok());
  EXPECT_EQ(kMap.check_write(Space::input, 0x0000, std::array<uint16_t, 1>{1}).code(),
            Errc::illegal_data_address);
  // The writable range is narrower than the documented one.
  EXPECT_EQ(kMap.check_write(Space::holding, 0x0012, std::array<uint16_t, 1>{900}).code(),
            Errc::illegal_data_value);
  EXPECT_EQ(
      kMap.check_write(Space::holding, 0x0012, std::array<uint16_t, 1>{static_cast<uint16_t>(-5)}).code(),
      Errc::illegal_data_value);
  // A choice takes only its named values.
  EXPECT_TRUE(kMap.check_write(Space::holding, 0x0011, std::array<uint16_t, 1>{3}).ok());
  EXPECT_EQ(kMap.check_write(Space::holding, 0x0011, std::array<uint16_t, 1>{2}).code(),
            Errc::illegal_data_value);
  // A 32-bit value is written whole or not at all.
  EXPECT_EQ(kMap.check_write(Space::holding, 0x0014, std::array<uint16_t, 1>{1}).code(),
            Errc::illegal_data_address);
  EXPECT_EQ(kMap.check_write(Space::holding, 0x0015, std::array<uint16_t, 1>{1}).code(),
            Errc::illegal_data_address);
  EXPECT_TRUE(kMap.check_write(Space::holding, 0x0014, std::array<uint16_t, 2>{1, 2}).ok());
  // Validated whole: one bad value in the middle refuses the request.
  EXPECT_EQ(kMap.check_write(Space::holding, 0x0100, std::array<uint16_t, 4>{10, 60, 101, 120}).code(),
            Errc::illegal_data_value);
}

TEST(ProfileMap, WordsAndValues) {
  const std::array<uint16_t, 2> low_first{0x5678, 0x1234};
  EXPECT_EQ(RegisterMap::decode(kRows[3], low_first), 0x12345678);
  std::array<uint16_t, 2> out{};
  RegisterMap::encode(kRows[3], 0x12345678, out);
  EXPECT_EQ(out, low_first);
  EXPECT_EQ(RegisterMap::decode(kRows[2], std::array<uint16_t, 1>{0xFFFB}), -5);
  EXPECT_DOUBLE_EQ(RegisterMap::to_number(kRows[2], 215), 21.5);
  EXPECT_EQ(*RegisterMap::from_number(kRows[2], 21.54), 215);
  EXPECT_EQ(RegisterMap::from_number(kRows[2], 120.0).error().code(), Errc::illegal_data_value);
}

TEST(ProfileImage, DefaultsAndHandles) {
  std::array<uint16_t, kMap.image_size()> words{};
  Image image(kMap, words);
  image.reset();
  EXPECT_EQ(image.get(kSpeed), 50);
  EXPECT_EQ(image.get(kRows[4], 0), 20);  // default_first
  EXPECT_EQ(image.get(kRows[4], 3), 0);
  EXPECT_EQ(image.get(kRows[2]), 250);
  image.set(kTotal, 70000);
  EXPECT_EQ(image.get(kTotal), 70000);
  std::array<uint16_t, 2> read{};
  image.read(Space::holding, 0x0014, read);
  EXPECT_EQ(read[0], 70000 & 0xFFFF);  // low word first, as the row says
}

TEST(ProfileModel, EngineServesItStrictly) {
  TestModel model;
  SlaveEngine engine;
  ASSERT_TRUE(engine.add_unit(UnitId{7}, model).ok());
  std::array<uint8_t, 256> out{};
  const auto ask = [&](std::initializer_list<uint8_t> pdu) {
    const std::vector<uint8_t> p(pdu);
    const size_t n = engine.handle_pdu(UnitId{7}, p, out).length;
    return std::vector<uint8_t>(out.begin(), out.begin() + static_cast<ptrdiff_t>(n));
  };
  // The functions come from the rows: no discrete inputs -> 01, even with a bad quantity.
  EXPECT_EQ(ask({0x02, 0x00, 0x00, 0x00, 0x00}), (std::vector<uint8_t>{0x82, 0x01}));
  EXPECT_EQ(ask({0x03, 0x00, 0x10, 0x00, 0x01}), (std::vector<uint8_t>{0x03, 0x02, 0x00, 50}));
  EXPECT_EQ(ask({0x03, 0x00, 0x13, 0x00, 0x01}), (std::vector<uint8_t>{0x83, 0x02}));
  EXPECT_EQ(ask({0x04, 0x00, 0x00, 0x00, 0x02}), (std::vector<uint8_t>{0x04, 0x04, 0x00, 0x01, 0x00, 0x02}));
  // All or nothing: the bad third value leaves the first two unwritten.
  EXPECT_EQ(ask({0x10, 0x01, 0x00, 0x00, 0x03, 0x06, 0x00, 10, 0x00, 60, 0x00, 101}),
            (std::vector<uint8_t>{0x90, 0x03}));
  EXPECT_EQ(model.image().get(kRows[4], 0), 20);
  EXPECT_EQ(model.applied, 0);
  // A device rule refuses with 04 and changes nothing.
  EXPECT_EQ(ask({0x05, 0x00, 0x00, 0xFF, 0x00}), (std::vector<uint8_t>{0x05, 0x00, 0x00, 0xFF, 0x00}));
  EXPECT_EQ(ask({0x06, 0x00, 0x10, 0x00, 80}), (std::vector<uint8_t>{0x86, 0x04}));
  EXPECT_EQ(model.image().get(kSpeed), 50);
  EXPECT_EQ(ask({0x01, 0x00, 0x00, 0x00, 0x01}), (std::vector<uint8_t>{0x01, 0x01, 0x01}));
}

TEST(ProfileText, FormatAndParse) {
  EXPECT_EQ(format_value(kRows[0], 80), "80 %");
  EXPECT_EQ(format_value(kRows[1], 3), "outdoor (3)");
  EXPECT_EQ(format_value(kRows[1], 2), "unknown (2)");
  EXPECT_EQ(format_value(kRows[2], -5), "-0.5 degC");
  EXPECT_EQ(format_value(kRows[3], 123456), "1234.56 kWh");
  EXPECT_EQ(format_value(kRows[5], 1800), "30:00");
  EXPECT_EQ(format_value(kRows[7], 0x00010002), "V1.2");
  EXPECT_EQ(format_value(kRows[8], 5), "over-voltage, over-current");
  EXPECT_EQ(format_value(kRows[8], 0), "none");
  EXPECT_EQ(format_value(kRows[9], 1), "on");

  EXPECT_EQ(*parse_value(kRows[0], "80"), 80);
  EXPECT_EQ(*parse_value(kRows[0], "80 %"), 80);
  EXPECT_EQ(*parse_value(kRows[0], "0x10"), 16);
  EXPECT_EQ(*parse_value(kRows[1], "Outdoor"), 3);
  EXPECT_EQ(*parse_value(kRows[2], "21.5"), 215);
  EXPECT_EQ(*parse_value(kRows[5], "30:00"), 1800);
  EXPECT_EQ(*parse_value(kRows[8], "over_voltage|over-current"), 5);
  EXPECT_EQ(*parse_value(kRows[9], "on"), 1);

  const Outcome<int64_t> fast = parse_value(kRows[1], "fast");
  EXPECT_EQ(fast.error().code(), Errc::invalid_argument);
  EXPECT_EQ(fast.error().reason(), "'fast' is not a mode (normal, indoor, outdoor)");
  const Outcome<int64_t> high = parse_value(kRows[0], "120");
  EXPECT_EQ(high.error().code(), Errc::illegal_data_value);
  EXPECT_EQ(high.error().reason(), "speed: 120 is outside 0..100 %");
  EXPECT_EQ(parse_value(kRows[2], "85").error().reason(), "limit: 85 is outside 0.0..80.0 degC");
  EXPECT_EQ(parse_value(kRows[5], "100:00").error().code(), Errc::illegal_data_value);
  EXPECT_EQ(parse_value(kRows[0], "eighty").error().code(), Errc::invalid_argument);
}

TEST(ProfileStateFile, RoundTripAndDamage) {
  test::TempDir dir;
  TestModel a;
  a.image().set(kSpeed, 77);
  a.image().set(kTotal, 99999);
  a.image().set(kRows[5], 1234, 2);
  const std::string path = dir / "sub/state.json";
  ASSERT_TRUE(save_state(path, kProfile, a.image()).ok());
  TestModel b;
  LoadedState loaded = load_state(path, kProfile, b.image());
  EXPECT_TRUE(loaded.from_file) << loaded.warning;
  EXPECT_EQ(b.image().get(kSpeed), 77);
  EXPECT_EQ(b.image().get(kTotal), 99999);
  EXPECT_EQ(b.image().get(kRows[5], 2), 1234);

  // Every damaged form falls back to the defaults with one reason, changing nothing.
  std::string text = state_to_text(kProfile, a.image());
  const std::string changed = std::string(text).replace(text.find("77"), 2, "78");
  const std::string out_of_range_body =
      R"({"format":"rtukit-state","version":1,"device":"testdev","registers":)";
  for (const auto& [bad, expected] : std::vector<std::pair<std::string, Errc>>{
           {text.substr(0, text.size() / 2), Errc::malformed},
           {changed, Errc::bad_crc},
           {R"({"some": "other program"})", Errc::malformed},
           {std::string(text).replace(text.find("testdev"), 7, "another"), Errc::malformed}}) {
    TestModel c;
    const Status s = state_from_text(kProfile, bad, c.image());
    EXPECT_EQ(s.code(), expected) << bad;
    EXPECT_EQ(c.image().get(kSpeed), 50);
  }
  std::ofstream(dir / "fifo-not.json") << "";
  TestModel d;
  loaded = load_state(dir / "missing.json", kProfile, d.image());
  EXPECT_FALSE(loaded.from_file);
  EXPECT_NE(loaded.warning.find("no state file"), std::string::npos);
}

TEST(ProfileStateFile, ValueOutOfRangeRefusedWhole) {
  TestModel a;
  std::string text = state_to_text(kProfile, a.image());
  // Rewrite speed to 150 and fix the checksum the way a careless tool would not.
  nlohmann::json j = nlohmann::json::parse(text);
  j["registers"]["speed"] = 150;
  const std::string body = j["registers"].dump();
  char crc[8];
  std::snprintf(crc, sizeof crc, "0x%04X",
                crc16({reinterpret_cast<const uint8_t*>(body.data()), body.size()}));
  j["checksum"] = crc;
  TestModel b;
  const Status s = state_from_text(kProfile, j.dump(), b.image());
  EXPECT_EQ(s.code(), Errc::illegal_data_value);
  EXPECT_EQ(b.image().get(kSpeed), 50);
}

TEST(ProfileMapFile, ExportLoadRoundTrip) {
  ASSERT_TRUE(check_profile(kProfile).ok()) << check_profile(kProfile).reason();
  for (const std::string& text : {map_to_yaml(kProfile), map_to_json(kProfile)}) {
    Outcome<std::unique_ptr<MapProfile>> loaded = parse_map(text, "export");
    ASSERT_TRUE(loaded.ok()) << loaded.error().reason() << "\n" << text;
    const Profile& p = (*loaded)->profile();
    EXPECT_EQ(p.name, kProfile.name);
    ASSERT_EQ(p.rows.size(), std::size(kRows));
    for (size_t i = 0; i < p.rows.size(); ++i) {
      const Row& a = kRows[i];
      const Row& b = p.rows[i];
      EXPECT_EQ(a.space, b.space);
      EXPECT_EQ(a.address, b.address);
      EXPECT_EQ(a.key, b.key);
      EXPECT_EQ(a.title, b.title);
      EXPECT_EQ(a.role, b.role);
      EXPECT_EQ(a.encoding, b.encoding);
      EXPECT_EQ(a.unit, b.unit);
      EXPECT_EQ(a.scale, b.scale);
      EXPECT_EQ(a.order, b.order);
      EXPECT_EQ(a.access, b.access);
      EXPECT_EQ(a.range, b.range);
      EXPECT_EQ(a.writable_range, b.writable_range);
      EXPECT_EQ(a.default_value, b.default_value);
      EXPECT_EQ(a.default_first, b.default_first);
      EXPECT_EQ(a.repeat, b.repeat);
      EXPECT_EQ(a.stride, b.stride);
      EXPECT_EQ(a.notes, b.notes);
      ASSERT_EQ(a.names.size(), b.names.size());
      for (size_t k = 0; k < a.names.size(); ++k) {
        EXPECT_EQ(a.names[k].value, b.names[k].value);
        EXPECT_EQ(a.names[k].name, b.names[k].name);
      }
      EXPECT_EQ(a.has(kPersisted), b.has(kPersisted)) << a.key;
      EXPECT_EQ(a.has(kMasked), b.has(kMasked)) << a.key;
    }
  }
}

TEST(ProfileMapFile, ErrorsNameTheLine) {
  const auto error_of = [](const std::string& text) {
    Outcome<std::unique_ptr<MapProfile>> m = parse_map(text, "m.yaml");
    EXPECT_FALSE(m.ok());
    return m.ok() ? std::string() : std::string(m.error().reason());
  };
  const std::string head = "device:\n  name: x\nregisters:\n";
  EXPECT_EQ(
      error_of(head + "  - key: a\n    address: 1\n    encoding: u61\n"),
      "m.yaml:6: unknown encoding 'u61' (u16, i16, u32, i32, choice, bits, duration, version, boolean)");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n  - key: b\n    address: 1\n"),
            "m.yaml:6: register 'b' (0x0001): address 0x0001 is covered by another register");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n    encoding: u32\n  - key: b\n    address: 2\n"),
            "m.yaml:7: register 'b' (0x0002): address 0x0002 is covered by another register");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n    range: [10, 5]\n"),
            "m.yaml:6: range [10, 5]: min is greater than max");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n    range: [10, 20]\n    default: 0\n"),
            "m.yaml:4: register 'a' (0x0001): default 0 is outside its range");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n    range: [0, 70000]\n"),
            "m.yaml:4: register 'a' (0x0001): range 0..70000 is outside what u16 can hold (0..65535)");
  EXPECT_EQ(
      error_of(head + "  - key: a\n    adress: 1\n"),
      "m.yaml:5: unknown field 'adress' in a register (fields: key, title, space, address, role, encoding, "
      "unit, scale, order, access, range, writable_range, default, default_first, flags, values, notes, "
      "repeat, stride)");
  EXPECT_EQ(error_of(head + "  - key: a\n    address: 1\n    encoding: choice\n"),
            "m.yaml:4: register 'a' (0x0001): a choice needs values");
  EXPECT_EQ(error_of("device: [1, 2\n").substr(0, 8), "m.yaml:2");
}

TEST(ProfileMapFile, ExampleMapsAreValid) {
  for (const char* name : {"energy-meter.yaml"}) {
    Outcome<std::unique_ptr<MapProfile>> m = load_map(std::string(EXAMPLES_DIR) + "/maps/" + name);
    ASSERT_TRUE(m.ok()) << m.error().reason();
    EXPECT_TRUE(check_profile((*m)->profile()).ok());
  }
}

}  // namespace
}  // namespace rtukit::profile
