// The simulated flash: round trip, damaged files fall back to defaults with a
// warning, and a process killed in the middle of saving never leaves a file
// that loads as a mix of two saves.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "process.hpp"
#include "rtukit/devices/inverjet/machine.hpp"
#include "rtukit/devices/profile/state_file.hpp"

namespace rtukit::inverjet {
namespace {

using test::TempDir;

// The settings a state file holds are the machine's persisted registers.
using Words = std::vector<uint16_t>;

Words persisted(const Machine& m) {
  Words out;
  for (const Row& r : kRows) {
    if (!r.has(profile::kPersisted)) continue;
    for (unsigned i = 0; i < r.repeat; ++i) out.push_back(static_cast<uint16_t>(m.image().get(r, i)));
  }
  return out;
}

// A machine whose stored registers all differ from the factory's (`seed` varies them).
std::unique_ptr<Machine> changed_settings(uint16_t seed) {
  auto m = std::make_unique<Machine>();
  profile::Image& im = m->image();
  im.set(reg::address, 1 + seed % 200);
  im.set(reg::baud, seed % 5);
  im.set(reg::control_mask, seed % 8);
  im.set(reg::free_speed, seed % 101);
  im.set(reg::free_time, seed * 7 % 6000);
  im.set(reg::timer_speed, (seed + 3) % 101);
  im.set(reg::timer_time, seed * 11 % 6000);
  for (unsigned p = 1; p <= kPlanCount; ++p)
    for (unsigned k = 0; k < kSegmentsPerPlan; ++k) {
      im.set(reg::plan_speed(p), (seed + k + p) % 101, k);
      im.set(reg::plan_end(p), (seed + 60 * (k + 1)) % 6000, k);
    }
  return m;
}

std::string settings_to_text(const std::unique_ptr<Machine>& m) {
  return profile::state_to_text(kProfile, m->image());
}
Status save_settings(const std::string& path, const std::unique_ptr<Machine>& m) {
  return profile::save_state(path, kProfile, m->image());
}

// What a simulator starting on `path` would have.
struct LoadedSettings {
  bool from_file;
  std::string warning;
  Words settings;
  bool foreign;
};
LoadedSettings load_settings(const std::string& path) {
  Machine m;
  const profile::LoadedState l = profile::load_state(path, kProfile, m.image());
  return {l.from_file, l.warning, persisted(m), l.foreign};
}
const Words kFactory = persisted(Machine{});

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(InverjetStateFile, SaveThenLoad_SameSettings) {
  TempDir dir;
  const auto s = changed_settings(42);
  ASSERT_FALSE(save_settings(dir / "sub/dir/state.json", s));  // creates the directories
  const LoadedSettings loaded = load_settings(dir / "sub/dir/state.json");
  EXPECT_TRUE(loaded.from_file);
  EXPECT_TRUE(loaded.warning.empty());
  EXPECT_EQ(loaded.settings, persisted(*s));
  EXPECT_NE(loaded.settings, kFactory);
}

TEST(InverjetStateFile, Missing_DefaultsWithWarning) {
  TempDir dir;
  const LoadedSettings loaded = load_settings(dir / "none.json");
  EXPECT_FALSE(loaded.from_file);
  EXPECT_NE(loaded.warning.find("no state file"), std::string::npos);
  EXPECT_EQ(loaded.settings, kFactory);
}

TEST(InverjetStateFile, Truncated_DefaultsWithWarning) {
  TempDir dir;
  const std::string text = settings_to_text(changed_settings(7));
  for (size_t cut : {size_t{0}, size_t{1}, text.size() / 3, text.size() / 2, text.size() - 3}) {
    write_text(dir / "state.json", text.substr(0, cut));
    const LoadedSettings loaded = load_settings(dir / "state.json");
    EXPECT_FALSE(loaded.from_file) << cut;
    EXPECT_NE(loaded.warning.find("damaged"), std::string::npos) << cut;
    EXPECT_FALSE(loaded.foreign) << cut;  // ours, cut short: saving may replace it
    EXPECT_EQ(loaded.settings, kFactory) << cut;
  }
}

TEST(InverjetStateFile, ChangedValue_ChecksumCatchesIt) {
  TempDir dir;
  const auto s = changed_settings(9);
  s->image().set(reg::timer_speed, 77);
  std::string text = settings_to_text(s);
  const size_t at = text.find("\"timer_speed\": 77");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 17, "\"timer_speed\": 78");  // still valid JSON, still in range
  write_text(dir / "state.json", text);
  const LoadedSettings loaded = load_settings(dir / "state.json");
  EXPECT_FALSE(loaded.from_file);
  EXPECT_NE(loaded.warning.find("checksum"), std::string::npos);
}

TEST(InverjetStateFile, OutOfRangeValue_Rejected) {
  TempDir dir;
  const auto s = std::make_unique<Machine>();
  s->image().set(reg::address, 0);  // not a valid address, even with a correct checksum
  write_text(dir / "state.json", settings_to_text(s));
  const LoadedSettings loaded = load_settings(dir / "state.json");
  EXPECT_FALSE(loaded.from_file);
  EXPECT_NE(loaded.warning.find("range"), std::string::npos);
}

TEST(InverjetStateFile, NotOurs_RejectedAsForeign) {
  TempDir dir;
  const auto foreign = [&](const std::string& path) {
    const LoadedSettings loaded = load_settings(path);
    EXPECT_FALSE(loaded.from_file) << path;
    EXPECT_TRUE(loaded.foreign) << path << ": " << loaded.warning;
    EXPECT_NE(loaded.warning.find("not a inverjet state file"), std::string::npos) << loaded.warning;
    EXPECT_EQ(loaded.settings, kFactory) << path;
  };
  write_text(dir / "other.json", "{\"hello\": 1}");  // another program's JSON
  foreign(dir / "other.json");
  write_text(dir / "other.json", "{\"format\": 5, \"device\": [\"inverjet\"]}");  // wrongly typed fields
  foreign(dir / "other.json");
  write_text(dir / "binary", std::string("\x00\x01\x02garbage", 10));
  foreign(dir / "binary");
  std::string text = settings_to_text(changed_settings(3));
  text.replace(text.find("\"inverjet\""), 10, "\"rehand6600\"");  // another device's state
  write_text(dir / "rehand.json", text);
  foreign(dir / "rehand.json");
  ASSERT_EQ(::mkdir((dir / "a-directory").c_str(), 0755), 0);
  foreign(dir / "a-directory");
  foreign("/dev/zero");  // read whole, it would never end
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0644), 0);
  foreign(dir / "fifo");  // opened without blocking: no writer is waited for
  write_text(dir / "big.json", "{");
  ASSERT_EQ(::truncate((dir / "big.json").c_str(), 256ll << 20), 0);
  foreign(dir / "big.json");  // 256 MiB (sparse): never read into memory
  ASSERT_EQ(::symlink("/nonexistent/target", (dir / "dangling").c_str()), 0);
  foreign(dir / "dangling");
}

TEST(InverjetStateFile, SaveNeverWritesThroughAPlantedSymlink) {
  TempDir dir;
  const std::string victim = dir / "victim.txt", path = dir / "state.json";
  write_text(victim, "someone else's file\n");
  // The temporary file's name is the state file's + ".tmp." + our pid: plant a link there.
  ASSERT_EQ(::symlink(victim.c_str(), (path + ".tmp." + std::to_string(::getpid())).c_str()), 0);
  ASSERT_FALSE(save_settings(path, changed_settings(5)));
  EXPECT_EQ(test::read_file(victim), "someone else's file\n");
  EXPECT_TRUE(load_settings(path).from_file);
  // A link planted at the state file itself is replaced by the file, its target untouched.
  ASSERT_EQ(::unlink(path.c_str()), 0);
  ASSERT_EQ(::symlink(victim.c_str(), path.c_str()), 0);
  ASSERT_FALSE(save_settings(path, changed_settings(6)));
  EXPECT_EQ(test::read_file(victim), "someone else's file\n");
  EXPECT_EQ(load_settings(path).settings, persisted(*changed_settings(6)));
}

// A child saves A, B, A, B... as fast as it can; we kill it (SIGKILL) at a
// random moment after its first save (the child says so on a pipe: on a busy
// machine a kill on a timer alone could land before the child ever saved,
// and then no kill landed mid-save in 40 rounds), 40 times. The file must always load, and be exactly A or B.
// A kill between creating the temporary file and the rename leaves that file
// behind; the next save removes it (its process is gone), so kills never
// pile files up.
TEST(InverjetStateFile, KilledDuringSaveLoop_NeverAMix) {
  TempDir dir;
  const std::string path = dir / "state.json";
  const auto a = changed_settings(1);
  const auto b = changed_settings(2);
  ASSERT_FALSE(save_settings(path, a));
  const auto temporaries = [&] {
    unsigned n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir.path()))
      n += e.path().filename().string().starts_with("state.json.tmp.") ? 1 : 0;
    return n;
  };
  std::mt19937 rng(12345);
  unsigned killed_mid_save = 0;
  for (int round = 0; round < 40; ++round) {
    int saved[2];
    ASSERT_EQ(::pipe(saved), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      ::close(saved[0]);
      (void)save_settings(path, b);
      (void)!::write(saved[1], "s", 1);
      for (unsigned i = 0;; ++i) (void)save_settings(path, i % 2 ? a : b);
    }
    ::close(saved[1]);
    char c = 0;
    ASSERT_EQ(::read(saved[0], &c, 1), 1) << "the child's first save";
    ::close(saved[0]);
    ::usleep(std::uniform_int_distribution<unsigned>(0, 3000)(rng));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    const LoadedSettings loaded = load_settings(path);
    ASSERT_TRUE(loaded.from_file) << "round " << round << ": " << loaded.warning;
    ASSERT_TRUE(loaded.settings == persisted(*a) || loaded.settings == persisted(*b)) << "round " << round;
    // At most the one this child left: earlier ones were removed by its saves.
    const unsigned left = temporaries();
    ASSERT_LE(left, 1u) << "round " << round;
    killed_mid_save += left;
  }
  // Proof that kills landed mid-save (each left its temporary file)...
  EXPECT_GT(killed_mid_save, 0u);
  // ...and that a save cleans up after a killed writer.
  ASSERT_FALSE(save_settings(path, a));
  EXPECT_EQ(temporaries(), 0u);
}

}  // namespace
}  // namespace rtukit::inverjet
