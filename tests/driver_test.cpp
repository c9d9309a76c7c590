// Master and slave drivers together, in one process, over every transport:
// pty (RTU), Modbus TCP and RTU-over-TCP.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>

#include "process.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/slave_server.hpp"
#include "rtukit/io/asio.hpp"
#include "rtukit/io/pty.hpp"
#include "rtukit/io/serial_config.hpp"

using namespace rtukit;
using namespace std::chrono_literals;
using test::TempDir;

namespace {

// A slave engine with one MemoryBank at unit 1, served on its own thread.
class SlaveOnThread {
 public:
  explicit SlaveOnThread(const std::string& listen, uint8_t unit = 1) {
    EXPECT_TRUE(engine.add_unit(UnitId{unit}, bank).ok());
    Result<io::PortSpec> spec = io::parse_port(listen, true);
    EXPECT_TRUE(spec.ok()) << spec.error().text();
    auto l = SlaveListener::start(ctx_, engine, *spec);
    EXPECT_TRUE(l.ok()) << l.error().reason();
    listener = std::move(*l);
    thread_ = std::thread([this] { ctx_.run(); });
  }
  ~SlaveOnThread() { stop(); }
  void stop() {
    if (!thread_.joinable()) return;
    asio::post(ctx_, [this] { listener.reset(); });
    work_.reset();
    ctx_.stop();
    thread_.join();
    listener.reset();
  }
  /// Runs `f` on the server's thread (the bank is the server's: touching it
  /// from the test thread while the server runs is a data race).
  template <class F>
  auto on_server(F f) {
    std::packaged_task<decltype(f())()> task(std::move(f));
    auto result = task.get_future();
    asio::post(ctx_, [&task] { task(); });
    return result.get();
  }
  /// A port string a master can use to reach this slave.
  std::string client_port() const {
    const std::string w = listener->where();
    return w;
  }

  MemoryBank bank{200};
  SlaveEngine engine;
  std::unique_ptr<SlaveListener> listener;

 private:
  asio::io_context ctx_;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work_{ctx_.get_executor()};
  std::thread thread_;
};

std::unique_ptr<Master> master_for(const std::string& port, MasterOptions options = {}) {
  Result<io::PortSpec> spec = io::parse_port(port, false);
  EXPECT_TRUE(spec.ok()) << spec.error().text();
  return std::make_unique<Master>(io::make_link(*spec), options);
}

// Every transport: the listen string for the slave.
class EveryTransport : public ::testing::TestWithParam<std::string> {};

std::string listen_string(const std::string& kind, const TempDir& dir) {
  if (kind == "pty") return "pty:" + (dir / "tty");
  if (kind == "tcp") return "tcp://127.0.0.1:0";
  return "rtu+tcp://127.0.0.1:0";
}

}  // namespace

TEST_P(EveryTransport, ReadWriteAndExceptions) {
  TempDir dir;
  SlaveOnThread slave(listen_string(GetParam(), dir));
  auto master = master_for(slave.client_port());
  const UnitId unit{1};

  const uint16_t values[] = {7, 8, 9};
  ASSERT_TRUE(master->write_multiple_registers(unit, 10, values).ok());
  ASSERT_TRUE(master->write_single_register(unit, 13, 0xBEEF).ok());
  std::array<uint16_t, 4> regs{};
  ASSERT_TRUE(master->read_holding_registers(unit, 10, regs).ok());
  EXPECT_EQ(regs, (std::array<uint16_t, 4>{7, 8, 9, 0xBEEF}));

  const uint8_t bits[] = {1, 0, 1};
  ASSERT_TRUE(master->write_multiple_coils(unit, 5, bits).ok());
  ASSERT_TRUE(master->write_single_coil(unit, 8, true).ok());
  std::array<uint8_t, 4> got{};
  ASSERT_TRUE(master->read_coils(unit, 5, got).ok());
  EXPECT_EQ(got, (std::array<uint8_t, 4>{1, 0, 1, 1}));

  slave.on_server([&] { slave.bank.input[3] = 4242; });
  uint16_t in = 0;
  ASSERT_TRUE(master->read_input_registers(unit, 3, {&in, 1}).ok());
  EXPECT_EQ(in, 4242);

  std::array<uint16_t, 2> past{};
  const Error e = master->read_holding_registers(unit, 199, past);
  EXPECT_TRUE(e.is_exception());
  EXPECT_EQ(e.code(), Errc::illegal_data_address);

  const MasterStats s = master->stats();
  EXPECT_EQ(s.requests, 8U);
  EXPECT_EQ(s.responses, 7U);
  EXPECT_EQ(s.exceptions, 1U);
  EXPECT_EQ(s.timeouts, 0U);
}

TEST_P(EveryTransport, SharedByEightThreads_RequestsAreSerialised) {
  TempDir dir;
  SlaveOnThread slave(listen_string(GetParam(), dir));
  auto master = master_for(slave.client_port());
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 25; ++i) {
        const auto value = static_cast<uint16_t>(t * 1000 + i);
        if (master->write_single_register(UnitId{1}, static_cast<uint16_t>(t), value)) ++failures;
        uint16_t back = 0;
        if (master->read_holding_registers(UnitId{1}, static_cast<uint16_t>(t), {&back, 1}) ||
            back != value) {
          ++failures;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(master->stats().responses, 400U);
}

INSTANTIATE_TEST_SUITE_P(Driver, EveryTransport, ::testing::Values("pty", "tcp", "rtu_tcp"));

TEST(MasterDriver, SilentUnit_TimesOutAfterRetries) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  MasterOptions o;
  o.response_timeout = 50ms;
  o.retries = 2;
  auto master = master_for(slave.client_port(), o);
  uint16_t r = 0;
  EXPECT_EQ(master->read_holding_registers(UnitId{9}, 0, {&r, 1}).code(), Errc::timeout);
  const MasterStats s = master->stats();
  EXPECT_EQ(s.requests, 3U);
  EXPECT_EQ(s.timeouts, 3U);
  EXPECT_EQ(s.retries, 2U);
}

TEST(MasterDriver, BroadcastWrite_IsExecutedWithoutAnAnswer) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  MasterOptions o;
  o.turnaround_delay = 20ms;
  auto master = master_for(slave.client_port(), o);
  ASSERT_TRUE(master->write_single_register(kBroadcast, 4, 77).ok());
  EXPECT_TRUE(test::eventually([&] { return slave.on_server([&] { return slave.bank.holding[4] == 77; }); }));
  EXPECT_EQ(master->stats().responses, 0U);
  uint16_t r = 0;
  EXPECT_EQ(master->read_holding_registers(kBroadcast, 0, {&r, 1}).code(), Errc::invalid_argument);
}

TEST(MasterDriver, DeviceThatDisappearsAndComesBack_IsReopened) {
  TempDir dir;
  const std::string link = dir / "tty";
  auto slave = std::make_unique<SlaveOnThread>("pty:" + link);
  MasterOptions o;
  o.response_timeout = 100ms;
  auto master = master_for(link, o);
  uint16_t r = 0;
  ASSERT_TRUE(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());

  slave.reset();  // "unplugged": the pty and its link are gone
  const Error gone = master->read_holding_registers(UnitId{1}, 0, {&r, 1});
  EXPECT_TRUE(gone.code() == Errc::io_error || gone.code() == Errc::timeout) << gone.name();
  EXPECT_EQ(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).code(), Errc::io_error);  // no device

  slave = std::make_unique<SlaveOnThread>("pty:" + link);  // plugged back in
  slave->on_server([&] { slave->bank.holding[0] = 99; });
  ASSERT_TRUE(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());
  EXPECT_EQ(r, 99);
  EXPECT_GE(master->stats().reopens, 2U);
}

TEST(MasterDriver, TcpServerRefused_IsAnIoError) {
  auto master = master_for("tcp://127.0.0.1:" + std::to_string(test::free_tcp_port()));
  uint16_t r = 0;
  const Error e = master->read_holding_registers(UnitId{1}, 0, {&r, 1});
  EXPECT_EQ(e.code(), Errc::io_error);
  EXPECT_EQ(e.os_error(), ECONNREFUSED);
}

TEST(MasterDriver, InterRequestDelay_IsKept) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  MasterOptions o;
  o.inter_request_delay = 30ms;
  auto master = master_for(slave.client_port(), o);
  uint16_t r = 0;
  ASSERT_TRUE(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());
  ASSERT_TRUE(master->read_holding_registers(UnitId{1}, 0, {&r, 1}).ok());
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 60ms);
}

TEST(SlaveServer, TcpServesManyConnectionsAtOnce) {
  SlaveOnThread slave("tcp://127.0.0.1:0");
  std::vector<std::unique_ptr<Master>> masters;
  for (int i = 0; i < 16; ++i) masters.push_back(master_for(slave.client_port()));
  for (auto& m : masters) ASSERT_TRUE(m->open().ok());  // 16 connections open together
  for (size_t i = 0; i < masters.size(); ++i) {
    ASSERT_TRUE(masters[i]
                    ->write_single_register(UnitId{1}, static_cast<uint16_t>(i), static_cast<uint16_t>(i + 1))
                    .ok());
  }
  for (size_t i = 0; i < masters.size(); ++i) {
    uint16_t r = 0;
    ASSERT_TRUE(masters[(i + 5) % masters.size()]
                    ->read_holding_registers(UnitId{1}, static_cast<uint16_t>(i), {&r, 1})
                    .ok());
    EXPECT_EQ(r, i + 1);
  }
}

TEST(SlaveServer, PtyLinkIsReplacedAndRemoved) {
  TempDir dir;
  const std::string link = dir / "tty";
  ASSERT_EQ(::symlink("/nonexistent", link.c_str()), 0);  // a stale link from a crashed run
  {
    SlaveOnThread slave("pty:" + link);
    EXPECT_TRUE(test::path_exists(link));
  }
  EXPECT_FALSE(test::path_exists(link));
}

// Who holds a pty link is told by its program's name and arguments, also
// when the program runs under qemu-user through binfmt_misc (the RK3588
// build's tests): CI's aarch64 stage said "aarch64-binfmt-P /check/...".
TEST(PtyLink, TheOwnerIsNamedByItsProgram_AlsoUnderAnEmulator) {
  using namespace std::string_literals;
  EXPECT_EQ(io::describe_command_line("/usr/bin/rtukit\0sim\0inverjet\0"s), "rtukit sim inverjet");
  EXPECT_EQ(
      io::describe_command_line(
          "/usr/libexec/qemu-binfmt/aarch64-binfmt-P\0/b/aarch64/cli/rtukit\0/b/aarch64/cli/rtukit\0sim\0inverjet\0"s),
      "rtukit sim inverjet");
  EXPECT_EQ(io::describe_command_line("/usr/bin/qemu-aarch64-static\0/b/rtukit\0sim\0rehand6600\0"s),
            "rtukit sim rehand6600");
  EXPECT_EQ(io::describe_command_line("socat\0-d\0pty,raw\0"s), "socat -d pty,raw");
  EXPECT_EQ(io::describe_command_line(""), "");
  const std::string long_line = io::describe_command_line("prog\0"s + std::string(300, 'x'));
  EXPECT_EQ(long_line.size(), 100u);
  EXPECT_TRUE(long_line.ends_with("..."));
}

TEST(PortSpec, ParsesEveryForm) {
  auto serial = io::parse_port("/dev/ttyUSB0", false);
  ASSERT_TRUE(serial.ok());
  EXPECT_EQ(serial->kind, io::PortSpec::Kind::serial);
  auto tcp = io::parse_port("tcp://localhost:1502", false);
  ASSERT_TRUE(tcp.ok());
  EXPECT_EQ(tcp->host, "localhost");
  EXPECT_EQ(tcp->port, 1502);
  auto rtu = io::parse_port("rtu+tcp://[::1]:4001", false);
  ASSERT_TRUE(rtu.ok());
  EXPECT_EQ(rtu->kind, io::PortSpec::Kind::rtu_tcp);
  EXPECT_EQ(rtu->host, "::1");
  EXPECT_FALSE(io::parse_port("pty", false).ok());
  EXPECT_TRUE(io::parse_port("pty:/tmp/x", true).ok());
  EXPECT_FALSE(io::parse_port("tcp://host:99999", false).ok());
  EXPECT_FALSE(io::parse_port("udp://host:1", false).ok());
  io::SerialSettings s;
  s.baud = 250000;  // non-standard: fine (BOTHER)
  EXPECT_TRUE(s.validate().ok());
  s.baud = 1000000;
  EXPECT_FALSE(s.validate().ok());
  s.baud = 9600;
  s.parity = 'X';
  EXPECT_FALSE(s.validate().ok());
}

namespace {

// A pty whose far side we drive by hand: what a device (or an adapter) sends.
struct HandDrivenPty {
  HandDrivenPty(const TempDir& dir) {
    auto p = io::Pty::create(dir / "dev");
    EXPECT_TRUE(p.ok()) << p.error().reason();
    pty = std::move(*p);
  }
  // Reads one chunk the master wrote (bounded wait).
  std::vector<uint8_t> read_request() {
    std::vector<uint8_t> buf(512);
    ssize_t n = -1;
    test::eventually([&] { return (n = ::read(pty.master_fd(), buf.data(), buf.size())) > 0; }, 2000ms);
    buf.resize(n > 0 ? static_cast<size_t>(n) : 0);
    return buf;
  }
  void send(const std::vector<uint8_t>& bytes) {
    EXPECT_EQ(::write(pty.master_fd(), bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }
  io::Pty pty;
};

}  // namespace

TEST(MasterDriver, HalfDuplexEcho_IsDiscarded_NotTakenForTheAnswer) {
  // For FC06 the echo of the request looks exactly like a success response.
  // The "device" here answers with exception 02 after the echo: only a master
  // that drops the echo reports the exception.
  for (const bool discard : {true, false}) {
    TempDir dir;
    HandDrivenPty dev(dir);
    MasterOptions o;
    o.discard_echo = discard;
    o.response_timeout = 500ms;
    auto master = master_for(dev.pty.name(), o);
    std::thread device([&] {
      const auto request = dev.read_request();
      dev.send(request);                         // the adapter's echo
      dev.send({0x01, 0x86, 0x02, 0xC3, 0xA1});  // the device's answer: exception 02
    });
    const Error e = master->write_single_register(UnitId{1}, 5, 42);
    device.join();
    if (discard) {
      EXPECT_EQ(e.code(), Errc::illegal_data_address) << e.name();
    } else {
      EXPECT_TRUE(e.ok()) << "without echo discard the echo passes for the answer";
    }
  }
}

namespace {

// Writes `frame` (its CRC appended) raw onto a slave's pty, as a foreign
// master would, and returns what comes back: up to `expect` bytes in 2 s.
std::vector<uint8_t> raw_exchange(const std::string& port, std::vector<uint8_t> frame, size_t expect) {
  const int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY);
  if (fd < 0 || !io::make_raw(fd).ok()) return {};
  const uint16_t crc = crc16(frame);
  frame.push_back(static_cast<uint8_t>(crc));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  std::vector<uint8_t> got;
  if (::write(fd, frame.data(), frame.size()) == static_cast<ssize_t>(frame.size()))
    test::eventually(
        [&] {
          uint8_t buf[16];
          const ssize_t n = ::read(fd, buf, sizeof buf);
          if (n > 0) got.insert(got.end(), buf, buf + n);
          return got.size() >= expect;
        },
        2000ms);
  ::close(fd);
  return got;
}

}  // namespace

TEST(SlaveServer, UnknownFunction_IsAnsweredAfterSilence_OnAPty) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  // FC 41 (user-defined): its length is unknown, so silence ends it.
  const std::vector<uint8_t> got = raw_exchange(slave.client_port(), {0x01, 0x41, 0x0E, 0x01, 0x00}, 5);
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[1], 0xC1);  // exception 01
  EXPECT_EQ(got[2], 0x01);
  EXPECT_TRUE(rtu_crc_ok(got));
}

// The last RTU framing gap (issue 14): a write-multiple request whose byte
// count disagrees with its length, CRC-valid over all its bytes, is answered
// 03 on a serial link as over Modbus TCP, not left unanswered.
TEST(SlaveServer, ByteCountDisagreeingWithTheLength_Is03OnAPty) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  // FC10, 2 registers, byte count 3 (should be 4), 4 data bytes.
  const std::vector<uint8_t> got = raw_exchange(
      slave.client_port(), {0x01, 0x10, 0x00, 0x00, 0x00, 0x02, 0x03, 0x00, 0x07, 0x00, 0x08}, 5);
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[1], 0x90);
  EXPECT_EQ(got[2], 0x03);  // illegal data value
  EXPECT_TRUE(rtu_crc_ok(got));
}

TEST(SerialLink, NonStandardBaudAndParity_ConfigureThroughTermios2) {
  TempDir dir;
  SlaveOnThread slave("pty:" + (dir / "tty"));
  Result<io::PortSpec> spec = io::parse_port(slave.client_port(), false);
  ASSERT_TRUE(spec.ok());
  spec->serial.baud = 250000;  // not a Bxxx constant: BOTHER
  spec->serial.parity = 'E';
  spec->serial.stop_bits = 2;
  Master master(io::make_link(*spec));
  uint16_t r = 0;
  const Error e = master.read_holding_registers(UnitId{1}, 0, {&r, 1});
  if (e.os_error() == ENOSYS)  // qemu-user (the aarch64 build's tests): only the standard rates
    GTEST_SKIP() << "no termios2 here: a rate that is not a Bxxx constant cannot be set";
  EXPECT_TRUE(e.ok()) << e.name();
  // Exclusive: a second opener of the same port is refused, even as root.
  Master second(io::make_link(*spec));
  const Error busy = second.open();
  EXPECT_EQ(busy.code(), Errc::io_error);
  EXPECT_EQ(busy.os_error(), EBUSY);
}

TEST(LinkTiming, UsbAdapterChunks16msApart_StillMakeOneFrame) {
  Result<io::PortSpec> spec = io::parse_port("/dev/ttyUSB0", false);
  ASSERT_TRUE(spec.ok());
  RtuFramer framer(FrameShape::request, io::link_timing(*spec));
  const uint8_t first[] = {0x15, 0x03, 0x00, 0x21};
  const uint8_t second[] = {0x00, 0x04, 0x17, 0x17};
  framer.feed(first, 0);
  EXPECT_FALSE(framer.next(0));
  framer.feed(second, 16'000);
  const auto frame = framer.next(16'000);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->adu.size(), 8U);
  // A truncated frame is still dropped once the silence is real.
  framer.feed(first, 100'000);
  EXPECT_FALSE(framer.next(100'000 + io::kLinuxSilenceFloorUs + 1));
  EXPECT_EQ(framer.buffered(), 0U);
}
