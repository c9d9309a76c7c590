// A link left by a simulator that died must not lead a client onto another
// program's pty (io/pty.hpp stale_pty_link, SerialLink::open): the pty
// number comes back for the next pty anyone makes, and a bridge reopening
// its port took another test's simulator that way (CI, 2026-11-26).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <thread>

#include "rtukit/io/link.hpp"
#include "rtukit/io/port.hpp"
#include "rtukit/io/pty.hpp"

namespace rtukit::io {
namespace {

std::unique_ptr<Link> link_to(const std::string& path) {
  Result<PortSpec> spec = parse_port(path, false);
  EXPECT_TRUE(spec.ok());
  return make_link(*spec);
}

TEST(PtyLink, ALinkToAPtyNewerThanItselfIsStale_AndNotOpened) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rtukit-pty-link-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  Outcome<Pty> pty = Pty::create("");
  ASSERT_TRUE(pty.ok()) << pty.error().reason();
  const std::string link = (dir / "jet").string();
  std::filesystem::create_symlink(pty->path(), link);
  // Made after the pty: the link the pty's owner made, live.
  EXPECT_FALSE(stale_pty_link(link));
  {
    auto live = link_to(link);
    EXPECT_FALSE(live->open()) << "a live link opens";
  }
  // The pty changes after the link (as a pty whose number came back for
  // someone else is newer than the link): its ctime, moved by a chmod to
  // the same mode, once the kernel's clock has ticked past the link's.
  struct stat st {};
  ASSERT_EQ(::stat(pty->path().c_str(), &st), 0);
  for (int i = 0; i < 2000 && !stale_pty_link(link); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_EQ(::chmod(pty->path().c_str(), st.st_mode & 07777), 0);
  }
  EXPECT_TRUE(stale_pty_link(link));
  auto stale = link_to(link);
  const Error e = stale->open();
  EXPECT_EQ(e.code(), Errc::io_error);
  EXPECT_EQ(e.os_error(), ENOENT) << "as if the port were absent";
  EXPECT_FALSE(stale->is_open());
  // The pty itself, by its own name, is anyone's to open; a plain file is no pty link.
  EXPECT_FALSE(stale_pty_link(pty->path()));
  EXPECT_FALSE(stale_pty_link((dir / "nothing").string()));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rtukit::io
