// The bus tap's character lines (docs/bus-tools.md) and where a named bus
// offers its tap (rtukit/term/tap_client.hpp): the text is a format other
// programs read, so it is pinned; a name that would not make a safe path is
// refused with the reason the CLI prints.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "rtukit/term/tap_client.hpp"

namespace rtukit::term {
namespace {

TEST(TapLine, FormatIsPinned) {
  EXPECT_EQ(tap_line({.start_us = 0, .end_us = 520, .sender = 1, .sent = 0x01, .heard = 0x01}),
            "0 520 1 01 01\n");
  EXPECT_EQ(tap_line({.start_us = 1'000'000'000'000,
                      .end_us = 1'000'000'000'520,
                      .sender = -1,
                      .sent = 0xAB,
                      .heard = 0x0F,
                      .collided = true}),
            "1000000000000 1000000000520 -1 AB 0F c\n");
  EXPECT_EQ(tap_line({.start_us = 5, .end_us = 6, .sender = 2, .sent = 0xFF, .heard = 0xFF, .dropped = true}),
            "5 6 2 FF FF d\n");
  EXPECT_EQ(tap_line({.start_us = 5,
                      .end_us = 6,
                      .sender = 2,
                      .sent = 0x10,
                      .heard = 0x90,
                      .collided = true,
                      .dropped = true}),
            "5 6 2 10 90 cd\n");
}

TEST(TapLine, ReadsBackWhatItWrites) {
  const std::vector<TapCharacter> characters = {
      {.start_us = 0, .end_us = 520, .sender = 1, .sent = 0x01, .heard = 0x01},
      {.start_us = 520, .end_us = 1040, .sender = -1, .sent = 0x00, .heard = 0x7E, .collided = true},
      {.start_us = 1'700'000'000'000'000,
       .end_us = 1'700'000'000'000'573,
       .sender = 30,
       .sent = 0xFE,
       .heard = 0xFE,
       .dropped = true},
      {.start_us = 9,
       .end_us = 10,
       .sender = 0,
       .sent = 0x55,
       .heard = 0xAA,
       .collided = true,
       .dropped = true},
  };
  for (const TapCharacter& c : characters) {
    const std::string line = tap_line(c);
    for (const std::string& text : {line, line.substr(0, line.size() - 1)}) {  // with and without '\n'
      const std::optional<TapCharacter> back = parse_tap_line(text);
      ASSERT_TRUE(back) << text;
      EXPECT_EQ(back->start_us, c.start_us) << text;
      EXPECT_EQ(back->end_us, c.end_us) << text;
      EXPECT_EQ(back->sender, c.sender) << text;
      EXPECT_EQ(back->sent, c.sent) << text;
      EXPECT_EQ(back->heard, c.heard) << text;
      EXPECT_EQ(back->collided, c.collided) << text;
      EXPECT_EQ(back->dropped, c.dropped) << text;
    }
  }
}

TEST(TapLine, CommentsAndOtherLinesAreNoCharacter) {
  EXPECT_FALSE(parse_tap_line(""));
  EXPECT_FALSE(parse_tap_line("# rtukit bus tap: ... baud=9600 bits=11 now_us=0"));
  EXPECT_FALSE(parse_tap_line("#0 520 1 01 01"));
  EXPECT_FALSE(parse_tap_line("0 520 1 01"));      // four fields
  EXPECT_FALSE(parse_tap_line("0 520 1 100 01"));  // sent above FF
  EXPECT_FALSE(parse_tap_line("0 520 1 01 1FF"));  // heard above FF
  EXPECT_FALSE(parse_tap_line("start end sender sent heard"));
  EXPECT_FALSE(parse_tap_line("0 520 x 01 01"));
}

// Sets (or, with nullptr, unsets) XDG_RUNTIME_DIR until destroyed.
class RuntimeDir {
 public:
  explicit RuntimeDir(const char* value) {
    if (const char* old = std::getenv("XDG_RUNTIME_DIR")) old_ = old;
    if (value)
      ::setenv("XDG_RUNTIME_DIR", value, 1);
    else
      ::unsetenv("XDG_RUNTIME_DIR");
  }
  ~RuntimeDir() {
    if (old_)
      ::setenv("XDG_RUNTIME_DIR", old_->c_str(), 1);
    else
      ::unsetenv("XDG_RUNTIME_DIR");
  }
  RuntimeDir(const RuntimeDir&) = delete;
  RuntimeDir& operator=(const RuntimeDir&) = delete;

 private:
  std::optional<std::string> old_;
};

TEST(BusTapSocket, InTheRuntimeFolderElseOnePerUserUnderTmp) {
  {
    const RuntimeDir dir("/run/user/1000");
    const Outcome<std::string> path = bus_tap_socket("lab-bus_2");
    ASSERT_TRUE(path.ok());
    EXPECT_EQ(*path, "/run/user/1000/rtukit/bus-lab-bus_2.sock");
  }
  const std::string tmp = "/tmp/rtukit-" + std::to_string(::getuid()) + "/bus-a.sock";
  for (const char* unset : {static_cast<const char*>(nullptr), ""}) {  // unset, or set but empty
    const RuntimeDir dir(unset);
    const Outcome<std::string> path = bus_tap_socket("a");
    ASSERT_TRUE(path.ok());
    EXPECT_EQ(*path, tmp);
  }
  const RuntimeDir dir("/run/user/1000");
  const Outcome<std::string> longest = bus_tap_socket(std::string(64, 'x'));  // the longest name
  ASSERT_TRUE(longest.ok());
  EXPECT_EQ(*longest, "/run/user/1000/rtukit/bus-" + std::string(64, 'x') + ".sock");
}

TEST(BusTapSocket, ANameThatIsNoSafePathPartIsRefused) {
  for (const std::string& name : {std::string(), std::string(65, 'x'), std::string("a/b"), std::string(".."),
                                  std::string("a b"), std::string("bus.1"), std::string("bus\n")}) {
    const Outcome<std::string> path = bus_tap_socket(name);
    ASSERT_FALSE(path.ok()) << name;
    EXPECT_EQ(path.error().code(), Errc::invalid_argument) << name;
    EXPECT_EQ(path.error().reason(), "bus name '" + name + "': use 1 to 64 letters, digits, '-' or '_'");
  }
}

}  // namespace
}  // namespace rtukit::term
