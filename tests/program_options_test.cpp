// The programs' option and file work, without the CLI: the bridge's machines
// from --unit/--id and its MQTT password file (inverjet_bridge), the pool
// panel's password file (inverjet_panel) and the Rehand host's default
// pairing file (rehand_host). The `rtukit` commands only pass their options
// here and print; these tests hold the rules themselves.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "rtukit/programs/inverjet_bridge.hpp"
#include "rtukit/programs/inverjet_panel.hpp"
#include "rtukit/programs/rehand_host.hpp"

namespace rtukit::programs {
namespace {

namespace fs = std::filesystem;

const std::string kIdRequired = "--id is required (the machine's name in the topics: rtukit/inverjet/ID/...)";

Outcome<std::vector<BridgeMachine>> machines(std::vector<std::string> units, std::string_view id) {
  return bridge_machines(units, id);
}

// ------------------------------------------------------ bridge: --unit, --id

TEST(BridgeMachines, NoUnitIsOneMachineAtTheFactoryAddressNamedById) {
  const auto m = machines({}, "pool1");
  ASSERT_TRUE(m) << m.error().reason();
  ASSERT_EQ(m->size(), 1u);
  EXPECT_EQ((*m)[0].unit, 21);  // the Inverjet's factory address
  EXPECT_EQ((*m)[0].id, "pool1");
}

TEST(BridgeMachines, OneUnitTakesTheId_DecimalOrHex) {
  for (const std::string unit : {"22", "0x16"}) {
    const auto m = machines({unit}, "pool1");
    ASSERT_TRUE(m) << unit << ": " << m.error().reason();
    ASSERT_EQ(m->size(), 1u);
    EXPECT_EQ((*m)[0].unit, 22) << unit;
    EXPECT_EQ((*m)[0].id, "pool1") << unit;
  }
}

TEST(BridgeMachines, OneUnitWithItsOwnIdNeedsNoId) {
  const auto m = machines({"23=lane3"}, "");
  ASSERT_TRUE(m) << m.error().reason();
  ASSERT_EQ(m->size(), 1u);
  EXPECT_EQ((*m)[0].unit, 23);
  EXPECT_EQ((*m)[0].id, "lane3");
}

TEST(BridgeMachines, SeveralUnitsKeepTheirOrder_OwnIdsOrIdDashUnit) {
  const auto m = machines({"22=lane2", "30", "21"}, "pool");
  ASSERT_TRUE(m) << m.error().reason();
  ASSERT_EQ(m->size(), 3u);
  EXPECT_EQ((*m)[0].unit, 22);
  EXPECT_EQ((*m)[0].id, "lane2");
  EXPECT_EQ((*m)[1].unit, 30);
  EXPECT_EQ((*m)[1].id, "pool-30");
  EXPECT_EQ((*m)[2].unit, 21);
  EXPECT_EQ((*m)[2].id, "pool-21");
}

TEST(BridgeMachines, AnEmptyUnitBeforeItsIdIsTheFactoryAddress) {
  const auto m = machines({"=lane1", "22=lane2"}, "");
  ASSERT_TRUE(m) << m.error().reason();
  ASSERT_EQ(m->size(), 2u);
  EXPECT_EQ((*m)[0].unit, 21);
  EXPECT_EQ((*m)[0].id, "lane1");
}

TEST(BridgeMachines, AMachineWithoutAnIdIsRefused) {
  for (const std::vector<std::string>& units :
       {std::vector<std::string>{}, {"21"}, {"21="}, {"21=lane1", "22="}, {"21", "22"}}) {
    const auto m = machines(units, "");
    ASSERT_FALSE(m) << units.size();
    EXPECT_EQ(m.error().code(), Errc::invalid_argument);
    EXPECT_EQ(m.error().reason(), kIdRequired);
  }
}

TEST(BridgeMachines, AUnitOutsideTheInverjetsRangeIsRefusedInTheCommandsWords) {
  const std::array<std::pair<const char*, const char*>, 4> cases{{
      {"255", "inverjet unit 255 is out of range 1..254"},
      {"0", "inverjet unit 0 is out of range 1..254"},
      {"x=lane", "inverjet unit 'x' is not a number (decimal, or hex as 0x21)"},
      {"0x100", "inverjet unit 0x100 is out of range 1..254"},
  }};
  for (const auto& [unit, reason] : cases) {
    const auto m = machines({"21=lane1", unit}, "pool");
    ASSERT_FALSE(m) << unit;
    EXPECT_EQ(m.error().code(), Errc::invalid_argument) << unit;
    EXPECT_EQ(m.error().reason(), reason);
  }
  // The first refusal in the order given: the unit, before the missing id.
  const auto both = machines({"300", "21"}, "");
  ASSERT_FALSE(both);
  EXPECT_EQ(both.error().reason(), "inverjet unit 300 is out of range 1..254");
}

// ------------------------------------------------ files in a test directory

class ProgramFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* tmp = std::getenv("TMPDIR");
    dir_ = fs::path(tmp && *tmp ? tmp : "/tmp") /
           ("rtukit-program-files-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const char* name) const { return (dir_ / name).string(); }
  static void write(const std::string& file, const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
  }
  static std::string read(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static unsigned mode(const std::string& file) {
    struct stat st {};
    EXPECT_EQ(::lstat(file.c_str(), &st), 0) << file;
    return st.st_mode & 07777;
  }
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    return names;
  }

  fs::path dir_;
};

// ---------------------------------------------- bridge: --password-file

TEST_F(ProgramFiles, MqttPasswordLosesItsTrailingLineEndsOnly) {
  const std::string file = path("mqtt.pw");
  write(file, " s3 cret\t\r\n\n");
  const Outcome<std::string> pw = read_mqtt_password(file);
  ASSERT_TRUE(pw) << pw.error().reason();
  EXPECT_EQ(*pw, " s3 cret\t");
}

TEST_F(ProgramFiles, MqttPasswordFileThatIsMissingLargeOrADirectoryIsRefused) {
  const Outcome<std::string> missing = read_mqtt_password(path("none.pw"));
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code(), Errc::io_error);

  const std::string big = path("big.pw");
  write(big, std::string(kMaxPasswordFile + 1, 'x'));
  const Outcome<std::string> large = read_mqtt_password(big);
  ASSERT_FALSE(large);
  EXPECT_NE(large.error().reason().find("larger than"), std::string_view::npos) << large.error().reason();

  write(big, std::string(kMaxPasswordFile, 'x'));  // at the limit: read whole
  const Outcome<std::string> full = read_mqtt_password(big);
  ASSERT_TRUE(full) << full.error().reason();
  EXPECT_EQ(full->size(), kMaxPasswordFile);

  EXPECT_FALSE(read_mqtt_password(dir_.string()));
}

// ------------------------------------------------- panel: the password file

TEST(PanelPassword, CharactersAreCodePointsNotBytes) {
  EXPECT_EQ(password_characters(""), 0u);
  EXPECT_EQ(password_characters("abcdefgh"), 8u);
  const std::string ecole = std::string("\xC3\xA9") + "cole";  // "école": 6 bytes
  EXPECT_EQ(password_characters(ecole), 5u);
  EXPECT_EQ(password_characters("\xF0\x9F\x8F\x8A"), 1u);  // one swimmer emoji: 4 bytes
}

TEST(PanelPassword, ShorterThanEightCharactersIsRefused) {
  EXPECT_FALSE(check_new_password("12345678"));
  const Status seven = check_new_password("1234567");
  ASSERT_TRUE(seven);
  EXPECT_EQ(seven.code(), Errc::invalid_argument);
  EXPECT_EQ(seven.reason(), "the password has 7 characters: at least 8, please");
  // Seven "é": 14 bytes, 7 characters.
  std::string accents;
  for (int i = 0; i < 7; ++i) accents += "\xC3\xA9";
  const Status wide = check_new_password(accents);
  ASSERT_TRUE(wide);
  EXPECT_EQ(wide.reason(), "the password has 7 characters: at least 8, please");
  EXPECT_FALSE(check_new_password(accents + "\xC3\xA9"));
}

TEST_F(ProgramFiles, PanelPasswordFileIsMode0600AndHoldsTheRecord) {
  const mode_t old = ::umask(022);
  const std::string file = path("panel.pw");
  const Status e = write_password_file(file, "correct horse", false);
  ::umask(old);
  ASSERT_FALSE(e) << e.reason();
  EXPECT_EQ(mode(file), 0600u);
  const std::string record = read(file);
  EXPECT_EQ(record.rfind("rtukit-panel-password pbkdf2-sha256 ", 0), 0u) << record;
  const Outcome<bool> right = check_password(record, "correct horse");
  ASSERT_TRUE(right);
  EXPECT_TRUE(*right);
  EXPECT_FALSE(*check_password(record, "wrong horse"));
  EXPECT_TRUE(load_password_record(file));  // the panel takes it
}

TEST_F(ProgramFiles, PanelPasswordFileRefusesWhatExistsUnlessForced) {
  const std::string file = path("panel.pw");
  write(file, "keep me\n");
  const std::string exists = file + " exists: not replaced (--force replaces it)";
  const Status checked = check_password_file_path(file, false);
  ASSERT_TRUE(checked);
  EXPECT_EQ(checked.code(), Errc::refused);
  EXPECT_EQ(checked.reason(), exists);
  const Status e = write_password_file(file, "correct horse", false);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.code(), Errc::refused);
  EXPECT_EQ(e.reason(), exists);
  EXPECT_EQ(read(file), "keep me\n");
  EXPECT_FALSE(check_password_file_path(file, true));
  EXPECT_FALSE(check_password_file_path(path("new.pw"), false));
}

TEST_F(ProgramFiles, PanelPasswordFileNeverGoesThroughASymlink) {
  const std::string link = path("panel.pw");
  const std::string target = path("elsewhere");
  fs::create_symlink(target, link);  // dangling
  const Status e = write_password_file(link, "correct horse", false);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.code(), Errc::refused);
  EXPECT_FALSE(fs::exists(target));
}

TEST_F(ProgramFiles, PanelPasswordForceReplacesTheFile) {
  const std::string file = path("panel.pw");
  ASSERT_FALSE(write_password_file(file, "first password", false));
  const std::string first = read(file);
  ::chmod(file.c_str(), 0644);
  const Status e = write_password_file(file, "second password", true);
  ASSERT_FALSE(e) << e.reason();
  const std::string second = read(file);
  EXPECT_NE(second, first);
  EXPECT_TRUE(*check_password(second, "second password"));
  EXPECT_FALSE(*check_password(second, "first password"));
  EXPECT_EQ(mode(file), 0600u);
  EXPECT_EQ(entries(), std::vector<std::string>{"panel.pw"});  // no temporary file left
}

TEST_F(ProgramFiles, PanelPasswordRefusedLeavesNothingBehind) {
  // A short password: no file made, and a forced replace keeps the old one.
  const std::string file = path("panel.pw");
  const Status short_pw = write_password_file(file, "short", false);
  ASSERT_TRUE(short_pw);
  EXPECT_EQ(short_pw.code(), Errc::invalid_argument);
  EXPECT_EQ(short_pw.reason(), "the password has 5 characters: at least 8, please");
  EXPECT_TRUE(entries().empty());

  write(file, "keep me\n");
  EXPECT_EQ(write_password_file(file, "short", true).code(), Errc::invalid_argument);
  EXPECT_EQ(read(file), "keep me\n");
  EXPECT_EQ(entries(), std::vector<std::string>{"panel.pw"});

  // A directory that does not exist: the OS's reason, with the path.
  const std::string nowhere = path("missing/panel.pw");
  const Status e = write_password_file(nowhere, "correct horse", false);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.code(), Errc::io_error);
  EXPECT_EQ(e.reason(), nowhere + ": No such file or directory");
  EXPECT_EQ(entries(), std::vector<std::string>{"panel.pw"});
}

// ------------------------------------------------- host: the pairing file

TEST(DefaultPairingFile, StateDirectoryThenHomeThenTheCurrentDirectory) {
  EXPECT_EQ(default_pairing_file("/var/lib/rtukit", "/home/pi"), "/var/lib/rtukit/rehand6600-pairing.json");
  EXPECT_EQ(default_pairing_file("/var/lib/rtukit", nullptr), "/var/lib/rtukit/rehand6600-pairing.json");
  EXPECT_EQ(default_pairing_file(nullptr, "/home/pi"),
            "/home/pi/.local/state/rtukit/rehand6600-pairing.json");
  EXPECT_EQ(default_pairing_file(nullptr, nullptr), "rehand6600-pairing.json");
}

}  // namespace
}  // namespace rtukit::programs
