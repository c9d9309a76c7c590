// `rtukit gateway` as installers run it: a generic slave on a pty stands for
// the serial bus (units 1 and 21), the gateway owns that pty, and clients
// come over Modbus TCP: our Master, the rtukit CLI, mbpoll and pymodbus.
#include "rtukit/driver/gateway.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "process.hpp"
#include "rtukit/base/clock.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/core/slave.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_bank.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/io/asio.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

const std::string kRtukit = RTUKIT_BIN;

class GatewayTest : public ::testing::Test {
 protected:
  void start(std::vector<std::string> gateway_options = {}) {
    bus_ = std::make_unique<Process>(std::vector<std::string>{kRtukit, "slave", "--listen", "pty:" + tty_,
                                                              "--unit", "1", "--unit", "21", "-v"});
    ASSERT_TRUE(bus_->wait_for_output("listening on")) << bus_->output();
    port_ = free_tcp_port();
    std::vector<std::string> argv{kRtukit,    "gateway", "--port",    tty_,
                                  "--listen", where(),   "--timeout", "200"};
    argv.insert(argv.end(), gateway_options.begin(), gateway_options.end());
    gateway_ = std::make_unique<Process>(argv);
    ASSERT_TRUE(gateway_->wait_for_output("listening on")) << gateway_->output();
  }
  std::string where() const { return "tcp://127.0.0.1:" + std::to_string(port_); }
  std::unique_ptr<Master> client() {
    return std::make_unique<Master>(io::make_link(*io::parse_port(where(), false)),
                                    MasterOptions{.response_timeout = 2000ms});
  }
  // Requests the bus saw (the slave's -v log: one "rx" line each).
  size_t bus_requests() const {
    const std::string out = bus_->output();
    size_t n = 0;
    for (size_t at = 0; (at = out.find("rx ", at)) != std::string::npos; ++at) ++n;
    return n;
  }

  TempDir dir_;
  std::string tty_ = dir_ / "tty";
  uint16_t port_ = 0;
  std::unique_ptr<Process> bus_;
  std::unique_ptr<Process> gateway_;
};

// A `--read-only` gateway in front of the slave, and a raw Modbus TCP client,
// so that any PDU can be sent and its answer seen byte for byte.
class GatewayReadOnly : public GatewayTest {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(start({"--read-only"}));
    fd_ = connect_to(port_);
    ASSERT_GE(fd_, 0);
    const timeval wait{3, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  }
  void TearDown() override {
    if (fd_ >= 0) ::close(fd_);
  }

  // One request to unit 21: the PDU of its answer, empty if none came within 3 s.
  std::vector<uint8_t> ask(const std::vector<uint8_t>& pdu) {
    const auto t = static_cast<uint16_t>(++transaction_);
    const auto length = static_cast<uint16_t>(pdu.size() + 1);
    std::vector<uint8_t> adu = {static_cast<uint8_t>(t >> 8),      static_cast<uint8_t>(t),      0,    0,
                                static_cast<uint8_t>(length >> 8), static_cast<uint8_t>(length), kUnit};
    adu.insert(adu.end(), pdu.begin(), pdu.end());
    if (::send(fd_, adu.data(), adu.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(adu.size())) return {};
    const auto read_exactly = [&](uint8_t* p, size_t n) {
      for (size_t got = 0; got < n;) {
        const ssize_t r = ::recv(fd_, p + got, n - got, 0);
        if (r <= 0) return false;
        got += static_cast<size_t>(r);
      }
      return true;
    };
    uint8_t h[7];
    if (!read_exactly(h, sizeof h) || load_be16(h) != t || h[6] != kUnit) return {};
    const uint16_t n = load_be16(h + 4);
    if (n < 2) return {};
    std::vector<uint8_t> answer(n - 1u);
    if (!read_exactly(answer.data(), answer.size())) return {};
    return answer;
  }

  // Every request PDU that reached unit 21 on the bus, in order (the slave's
  // -v log: "rx UNIT PDU... CRC CRC -> tx ..."). Waits until `last` (a read
  // sent after everything else) is among them, so the log is complete.
  std::vector<std::vector<uint8_t>> bus_saw_after(const std::vector<uint8_t>& last) {
    std::vector<std::vector<uint8_t>> pdus;
    eventually([&] {
      pdus.clear();
      std::istringstream log(bus_->output());
      for (std::string line; std::getline(log, line);) {
        const size_t rx = line.find("rx "), arrow = line.find(" ->");
        if (rx != 0 || arrow == std::string::npos) continue;
        std::istringstream bytes(line.substr(3, arrow - 3));
        std::vector<uint8_t> frame;
        for (unsigned b = 0; bytes >> std::hex >> b;) frame.push_back(static_cast<uint8_t>(b));
        if (frame.size() < 4 || frame[0] != kUnit) continue;
        pdus.emplace_back(frame.begin() + 1, frame.end() - 2);  // without unit and CRC
      }
      return !pdus.empty() && pdus.back() == last;
    });
    return pdus;
  }

  static constexpr uint8_t kUnit = 21;
  int fd_ = -1;
  unsigned transaction_ = 0;
};

// The read-only allow-list, written out from the issue that defined it.
bool fc08_reads_only(uint16_t sub_function) {
  return sub_function == 0x00 || sub_function == 0x02 || (sub_function >= 0x0B && sub_function <= 0x12);
}

}  // namespace

// The checks every request passes on arrival, without a session or a bus.
TEST(GatewayAdmission, CodecThenUnitThenReadOnly) {
  using A = GatewayAdmission::Action;
  const std::vector<uint8_t> read = {0x03, 0x00, 0x21, 0x00, 0x04}, write = {0x06, 0x00, 0x80, 0x00, 0x32},
                             restart = {0x08, 0x00, 0x01, 0x00, 0x00}, echo = {0x08, 0x00, 0x00, 0x12, 0x34},
                             short_read = {0x03, 0x00}, unknown = {0x41, 0x00};
  const GatewayOptions open{}, read_only{.read_only = true}, listed{.allowed_units = {21}};

  const GatewayAdmission relayed = admit_gateway_request(open, 21, read, false);
  EXPECT_EQ(relayed.action, A::relay);
  EXPECT_EQ(relayed.request.address, 0x21);
  EXPECT_EQ(relayed.request.quantity, 4);
  EXPECT_EQ(admit_gateway_request(open, 248, read, false).exception, Errc::gateway_path_unavailable);
  // Unit 0: the serial line's broadcast, for the writes a broadcast carries
  // (issue 38: every request to unit 0 got a bare 0A). A read has nobody to
  // answer it; a list never lets a broadcast through; read-only refuses it.
  EXPECT_EQ(admit_gateway_request(open, 0, write, false).action, A::relay);
  EXPECT_EQ(admit_gateway_request(open, 0, read, false).exception, Errc::gateway_path_unavailable);
  EXPECT_EQ(admit_gateway_request(open, 0, echo, false).exception, Errc::gateway_path_unavailable);
  EXPECT_EQ(admit_gateway_request(listed, 0, write, false).exception, Errc::gateway_path_unavailable);
  // Not even a list that names 0 (the fuzz target's property, CI 2026-12-01).
  const GatewayOptions lists_zero{.allowed_units = {0, 21}};
  EXPECT_EQ(admit_gateway_request(lists_zero, 0, write, false).exception, Errc::gateway_path_unavailable);
  EXPECT_EQ(admit_gateway_request(read_only, 0, write, false).exception, Errc::illegal_function);
  const std::vector<uint8_t> read_write = {0x17, 0, 0, 0, 1, 0, 0, 0, 1, 2, 0, 7};
  EXPECT_EQ(admit_gateway_request(open, 0, read_write, false).exception, Errc::gateway_path_unavailable);
  EXPECT_EQ(admit_gateway_request(listed, 22, read, false).exception, Errc::gateway_path_unavailable);
  EXPECT_EQ(admit_gateway_request(listed, 21, write, false).action, A::relay);
  EXPECT_EQ(admit_gateway_request(read_only, 21, write, false).exception, Errc::illegal_function);
  EXPECT_EQ(admit_gateway_request(read_only, 21, restart, false).exception, Errc::illegal_function);
  EXPECT_EQ(admit_gateway_request(read_only, 21, echo, false).action, A::relay);
  EXPECT_EQ(admit_gateway_request(read_only, 21, read, false).action, A::relay);
  // Too short for its function: 03 to an MBAP client (its length said whole), dropped as an RTU frame.
  EXPECT_EQ(admit_gateway_request(open, 21, short_read, false).exception, Errc::illegal_data_value);
  EXPECT_EQ(admit_gateway_request(open, 21, short_read, true).action, A::drop);
  // A function not relayed: 01 both ways.
  EXPECT_EQ(admit_gateway_request(open, 21, unknown, true).exception, Errc::illegal_function);
  EXPECT_TRUE(gateway_counts_as_write(0x17));
  EXPECT_FALSE(gateway_counts_as_write(0x03));
}

TEST_F(GatewayTest, RelaysReadsWritesAndTheDevicesOwnExceptions) {
  start();
  auto m = client();
  const uint16_t values[] = {11, 22, 33};
  ASSERT_TRUE(m->write_multiple_registers(UnitId{21}, 0x21, values).ok());
  std::array<uint16_t, 3> regs{};
  ASSERT_TRUE(m->read_holding_registers(UnitId{21}, 0x21, regs).ok());
  EXPECT_EQ(regs, (std::array<uint16_t, 3>{11, 22, 33}));
  ASSERT_TRUE(m->write_single_coil(UnitId{1}, 3, true).ok());
  std::array<uint8_t, 2> bits{};
  ASSERT_TRUE(m->read_coils(UnitId{1}, 3, bits).ok());
  EXPECT_EQ(bits, (std::array<uint8_t, 2>{1, 0}));
  // The device's exception travels unchanged.
  std::array<uint16_t, 2> past{};
  EXPECT_EQ(m->read_holding_registers(UnitId{1}, 9999, past).code(), Errc::illegal_data_address);
  // The CLI works through it unchanged.
  const RunResult r = run({kRtukit, "read", "--port", where(), "--unit", "21", "0x21", "3"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("33 (0x0021): 11"), std::string::npos) << r.output;
}

TEST_F(GatewayTest, SilentUnitIs0B_NotAllowedIs0A_ReadOnlyIs01) {
  start({"--allow-units", "1,9", "--read-only"});
  auto m = client();
  uint16_t v = 0;
  EXPECT_TRUE(m->read_holding_registers(UnitId{1}, 0, {&v, 1}).ok());
  EXPECT_EQ(m->read_holding_registers(UnitId{9}, 0, {&v, 1}).code(), Errc::gateway_target_failed);
  EXPECT_EQ(m->read_holding_registers(UnitId{21}, 0, {&v, 1}).code(), Errc::gateway_path_unavailable);
  EXPECT_EQ(m->write_single_register(UnitId{1}, 0, 5).code(), Errc::illegal_function);
  ASSERT_TRUE(m->read_holding_registers(UnitId{1}, 0, {&v, 1}).ok());
  EXPECT_EQ(v, 0);  // nothing was written
  const RunResult r = run({kRtukit, "read", "--port", where(), "--unit", "9", "0"});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("exception 0B"), std::string::npos) << r.output;
}

// Unit 0 through the gateway (issue 38): a write is broadcast on the line,
// every unit executes it, and the client gets the write's normal answer; a
// read gets 0A and the gateway says once, on its console, what unit 0 is.
TEST_F(GatewayTest, UnitZeroBroadcastsAWrite_AReadIs0AWithAReason) {
  start();
  auto m = client();
  ASSERT_TRUE(m->write_single_register(UnitId{0}, 0x30, 77).ok());
  for (const uint8_t unit : {1, 21}) {
    uint16_t v = 0;
    ASSERT_TRUE(m->read_holding_registers(UnitId{unit}, 0x30, {&v, 1}).ok());
    EXPECT_EQ(v, 77) << "unit " << int(unit);
  }
  uint16_t v = 0;
  EXPECT_EQ(m->read_holding_registers(UnitId{0}, 0x30, {&v, 1}).code(), Errc::gateway_path_unavailable);
  EXPECT_EQ(m->read_holding_registers(UnitId{0}, 0x30, {&v, 1}).code(), Errc::gateway_path_unavailable);
  EXPECT_TRUE(gateway_->wait_for_output("to read, name the device's unit (1..247)")) << gateway_->output();
  const std::string out = gateway_->output();
  EXPECT_NE(out.find("gateway: a client asked unit 0 for an answer (function 03): answered 0A. Unit 0 is the "
                     "serial line's broadcast address"),
            std::string::npos)
      << out;
  size_t told = 0;
  for (size_t at = 0; (at = out.find("asked unit 0", at)) != std::string::npos; ++at) ++told;
  EXPECT_EQ(told, 1u) << out;  // once for the client, not a line per request
}

// Diagnostics and identification pass through (issue 14); a read-only
// gateway refuses what would change the device's line state.
TEST_F(GatewayTest, DiagnosticsAndIdentificationThroughTheGateway) {
  start({"--read-only"});
  auto m = client();
  const uint8_t echo[] = {1, 2, 3};
  std::vector<uint8_t> answer;
  ASSERT_TRUE(m->diagnostics(UnitId{21}, Diagnostic::return_query_data, echo, answer).ok());
  EXPECT_EQ(answer, (std::vector<uint8_t>{1, 2, 3}));
  uint16_t messages = 0;
  ASSERT_TRUE(m->diagnostic_value(UnitId{21}, Diagnostic::bus_message_count, messages).ok());
  EXPECT_GE(messages, 2);
  Master::DeviceIdentification id;
  ASSERT_TRUE(m->read_device_identification(UnitId{21}, DeviceIdAccess::basic, id).ok());
  EXPECT_EQ(id.objects[0], "rtukit");
  const uint8_t zero[] = {0, 0};
  EXPECT_EQ(m->diagnostics(UnitId{21}, Diagnostic::clear_counters, zero, answer).code(),
            Errc::illegal_function);
  EXPECT_EQ(m->diagnostics(UnitId{21}, Diagnostic::force_listen_only, zero, answer).code(),
            Errc::ok);  // sent...
  // ...but refused with 01 by the gateway, so the device still answers.
  uint16_t v = 0;
  EXPECT_TRUE(m->read_holding_registers(UnitId{21}, 0, {&v, 1}).ok());
}

// The bus goes away after the start (the slave ends: its pty is gone; a USB
// adapter unplugged): 0A, and the gateway keeps serving its clients.
TEST_F(GatewayTest, BusDownIs0A) {
  start();
  auto m = client();
  uint16_t v = 0;
  ASSERT_TRUE(m->read_holding_registers(UnitId{1}, 0, {&v, 1}).ok());
  bus_->stop();
  ASSERT_FALSE(path_exists(tty_));
  EXPECT_TRUE(eventually([&] {
    return m->read_holding_registers(UnitId{1}, 0, {&v, 1}).code() == Errc::gateway_path_unavailable;
  })) << gateway_->output();
  EXPECT_EQ(m->read_holding_registers(UnitId{1}, 0, {&v, 1}).code(), Errc::gateway_path_unavailable);
  EXPECT_TRUE(gateway_->running());
}

// A port that does not exist, or a file that is no serial port, ends the
// gateway at its start: one line, exit 4 (I/O), as `inverjet panel` and
// `bridge` do, and nothing listens. Before, it said "listening on" and
// answered every request 0A.
TEST_F(GatewayTest, FailsAtStartOnABadPort) {
  const std::string regular = dir_ / "not-a-tty";
  std::ofstream(regular) << "x";
  port_ = free_tcp_port();
  struct Case {
    std::string port;
    std::string says;
  };
  const std::vector<Case> cases = {
      {dir_ / "nothing",
       "rtukit: gateway: port " + dir_ / "nothing" + " 9600 8N1: No such file or directory\n"},
      {regular, "rtukit: gateway: port " + regular + " 9600 8N1: not a serial port\n"},
  };
  for (const Case& c : cases) {
    const RunResult r = run({kRtukit, "gateway", "--port", c.port, "--listen", where()}, 5000ms);
    EXPECT_EQ(r.code, 4) << c.port << ": " << r.output;
    EXPECT_EQ(r.output, c.says);
    const int fd = connect_to(port_);
    EXPECT_EQ(fd, -1) << c.port << ": something listens on " << where();
    if (fd >= 0) ::close(fd);
  }
}

TEST_F(GatewayTest, ManyClientsAtOnce_EachGetsItsOwnAnswers) {
  start();
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      auto m = client();
      for (int i = 0; i < 20; ++i) {
        const auto value = static_cast<uint16_t>(t * 100 + i);
        if (m->write_single_register(UnitId{1}, static_cast<uint16_t>(t), value)) ++failures;
        uint16_t back = 0;
        if (m->read_holding_registers(UnitId{1}, static_cast<uint16_t>(t), {&back, 1}) || back != value)
          ++failures;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
}

// A client that pipelines 30 requests does not starve one that sends one:
// the queues are served round robin, so the lone request is answered after
// at most one of the greedy client's requests per turn.
TEST_F(GatewayTest, FairBetweenClients) {
  start({"--max-queued", "64", "--delay", "20"});  // a slow bus: 30 requests take 0.6 s
  const int greedy = connect_to(port_);
  ASSERT_GE(greedy, 0);
  std::vector<uint8_t> burst;
  for (uint16_t i = 0; i < 30; ++i) {
    const uint8_t req[] = {
        static_cast<uint8_t>(i >> 8), static_cast<uint8_t>(i), 0, 0, 0, 6, 1, 3, 0, 0, 0, 125};
    burst.insert(burst.end(), std::begin(req), std::end(req));
  }
  ASSERT_EQ(::send(greedy, burst.data(), burst.size(), 0), static_cast<ssize_t>(burst.size()));
  ASSERT_TRUE(eventually([&] { return bus_requests() >= 1; }));
  auto m = client();
  uint16_t v = 0;
  ASSERT_TRUE(m->read_holding_registers(UnitId{21}, 0, {&v, 1}).ok());
  // The lone request went out long before the last of the burst.
  const std::string log = bus_->output();
  const size_t lone = log.find("rx 15 03");
  ASSERT_NE(lone, std::string::npos) << log;
  size_t before = 0;
  for (size_t at = 0; (at = log.find("rx 01 03", at)) != std::string::npos && at < lone; ++at) ++before;
  EXPECT_LT(before, 10u) << "the lone request waited for the burst";
  ::close(greedy);
}

TEST_F(GatewayTest, CoalescedReadsShareTheBus_AWriteIsNeverHidden) {
  start({"--cache-ms", "5000"});
  auto a = client();
  auto b = client();
  uint16_t v = 0;
  ASSERT_TRUE(a->read_holding_registers(UnitId{1}, 7, {&v, 1}).ok());
  const size_t after_first = bus_requests();
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(b->read_holding_registers(UnitId{1}, 7, {&v, 1}).ok());
  EXPECT_EQ(bus_requests(), after_first);  // ten reads, no bus transaction
  ASSERT_TRUE(b->write_single_register(UnitId{1}, 7, 4321).ok());
  ASSERT_TRUE(a->read_holding_registers(UnitId{1}, 7, {&v, 1}).ok());
  EXPECT_EQ(v, 4321);  // the cache did not hide the write
  // A write to another register leaves this read cached.
  ASSERT_TRUE(b->write_single_register(UnitId{1}, 8, 1).ok());
  const size_t before = bus_requests();
  ASSERT_TRUE(a->read_holding_registers(UnitId{1}, 7, {&v, 1}).ok());
  EXPECT_EQ(bus_requests(), before);
  ::kill(gateway_->pid(), SIGTERM);
  EXPECT_EQ(gateway_->wait(3000ms), 0);
  EXPECT_NE(gateway_->output().find("from the cache"), std::string::npos) << gateway_->output();
}

// Pollers that ask at the same moment queue behind one another; with a cache
// the first answer serves the reads waiting behind it (a 9600-baud line
// shared by many windows).
TEST_F(GatewayTest, QueuedIdenticalReadsShareOneTransaction) {
  start({"--cache-ms", "5000", "--delay", "20"});
  const size_t before = bus_requests();
  std::atomic<int> ok{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      auto m = client();
      uint16_t v = 0;
      if (m->read_holding_registers(UnitId{21}, 3, {&v, 1}).ok()) ++ok;
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(ok.load(), 8);
  EXPECT_LE(bus_requests() - before, 2u) << "8 identical reads should share the bus";
}

// FC16 and FC17 through the gateway: relayed as the device answers them,
// and as writes they invalidate the cached reads they change.
TEST_F(GatewayTest, MaskWriteAndReadWrite_RelayedAndNeverHiddenByTheCache) {
  start({"--cache-ms", "5000"});
  auto m = client();
  ASSERT_TRUE(m->write_single_register(UnitId{1}, 9, 0x12).ok());
  uint16_t v = 0;
  ASSERT_TRUE(m->read_holding_registers(UnitId{1}, 9, {&v, 1}).ok());  // now cached
  ASSERT_TRUE(m->mask_write_register(UnitId{1}, 9, 0x00F2, 0x0025).ok());
  ASSERT_TRUE(m->read_holding_registers(UnitId{1}, 9, {&v, 1}).ok());
  EXPECT_EQ(v, 0x17);  // not the cached 0x12
  const uint16_t values[] = {7, 8};
  std::array<uint16_t, 3> after{};
  ASSERT_TRUE(m->read_write_multiple_registers(UnitId{1}, 8, after, 9, values).ok());
  EXPECT_EQ(after, (std::array<uint16_t, 3>{0, 7, 8}));
  ASSERT_TRUE(m->read_holding_registers(UnitId{1}, 9, {&v, 1}).ok());
  EXPECT_EQ(v, 7);  // the FC17 write invalidated the cache too
}

TEST_F(GatewayTest, MbpollAndPymodbusThroughTheGateway) {
  start();
  auto m = client();
  const uint16_t values[] = {7, 8};
  ASSERT_TRUE(m->write_multiple_registers(UnitId{1}, 0, values).ok());
  const RunResult mb = run({"mbpoll", "-m", "tcp", "-p", std::to_string(port_), "-a", "1", "-r", "1", "-c",
                            "2", "-1", "127.0.0.1"});
  EXPECT_EQ(mb.code, 0) << mb.output;
  EXPECT_NE(mb.output.find("[1]: \t7"), std::string::npos) << mb.output;
  const std::string py =
      "from pymodbus.client import ModbusTcpClient\n"
      "c = ModbusTcpClient('127.0.0.1', port=" +
      std::to_string(port_) +
      ")\n"
      "c.connect()\n"
      "r = c.read_holding_registers(0, 2, slave=1)\n"
      "print('values', r.registers)\n";
  const RunResult p = run({"/usr/bin/python3", "-c", py});
  EXPECT_EQ(p.code, 0) << p.output;
  EXPECT_NE(p.output.find("values [7, 8]"), std::string::npos) << p.output;
}

// RTU frames over TCP (`--listen rtu+tcp://`): the clients of serial-minded
// tools. No transaction ids, so answers come in the order of the requests,
// the gateway's own answers (a unit not allowed, a cached read) included; a
// frame with a bad CRC gets no answer, as on a line.
TEST_F(GatewayTest, RtuOverTcpListener_AnswersInOrder_BadCrcIsSilent) {
  const uint16_t rtu_port = free_tcp_port();
  const std::string rtu_where = "rtu+tcp://127.0.0.1:" + std::to_string(rtu_port);
  start({"--listen", rtu_where, "--allow-units", "1,21", "--cache-ms", "500"});
  EXPECT_NE(gateway_->output().find(rtu_where), std::string::npos) << gateway_->output();
  // Our master and the CLI speak rtu+tcp:// unchanged.
  Master m(io::make_link(*io::parse_port(rtu_where, false)), MasterOptions{.response_timeout = 2000ms});
  ASSERT_TRUE(m.write_single_register(UnitId{21}, 0x21, 4321).ok());
  std::array<uint16_t, 1> reg{};
  ASSERT_TRUE(m.read_holding_registers(UnitId{21}, 0x21, reg).ok());
  EXPECT_EQ(reg[0], 4321);
  const RunResult r = run({kRtukit, "read", "--port", rtu_where, "--unit", "21", "0x21", "1"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("4321"), std::string::npos) << r.output;

  // Raw: three requests in one write, a bad CRC in the middle, a refused one last.
  const int fd = connect_to(rtu_port);
  ASSERT_GE(fd, 0);
  const auto frame = [](std::vector<uint8_t> b) {
    const uint16_t crc = rtukit::crc16(b);
    b.push_back(static_cast<uint8_t>(crc));
    b.push_back(static_cast<uint8_t>(crc >> 8));
    return b;
  };
  std::vector<uint8_t> out = frame({21, 0x03, 0x00, 0x21, 0x00, 0x01});  // a read of 0x21 (queued)
  std::vector<uint8_t> bad = frame({21, 0x06, 0x00, 0x21, 0x00, 0x07});  // a write, its CRC broken
  bad.back() ^= 0xFF;
  out.insert(out.end(), bad.begin(), bad.end());
  const std::vector<uint8_t> refused = frame({5, 0x03, 0x00, 0x00, 0x00, 0x01});  // unit 5: not allowed
  out.insert(out.end(), refused.begin(), refused.end());
  ASSERT_EQ(::write(fd, out.data(), out.size()), static_cast<ssize_t>(out.size()));
  std::vector<uint8_t> in;
  const std::vector<uint8_t> want_read = frame({21, 0x03, 0x02, 0x10, 0xE1});  // 4321
  const std::vector<uint8_t> want_refused = frame({5, 0x83, 0x0A});
  eventually([&] {
    uint8_t buf[256];
    const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) in.insert(in.end(), buf, buf + n);
    return in.size() >= want_read.size() + want_refused.size();
  });
  std::this_thread::sleep_for(300ms);  // anything more (an answer to the bad frame) would arrive now
  uint8_t buf[256];
  const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
  if (n > 0) in.insert(in.end(), buf, buf + n);
  ::close(fd);
  std::vector<uint8_t> want = want_read;
  want.insert(want.end(), want_refused.begin(), want_refused.end());
  EXPECT_EQ(in, want);  // the read first, then the refusal; nothing for the bad frame
  ASSERT_TRUE(m.read_holding_registers(UnitId{21}, 0x21, reg).ok());
  EXPECT_EQ(reg[0], 4321);  // the write with the bad CRC never reached the bus
}

// The allow-list of a read-only gateway, entry by entry, without a bus: every
// function code, every FC08 sub-function, every FC2B MEI type. Anything it does
// not name is refused with 01, including what a deny-list would let through.
TEST(GatewayReadOnlyAdmission, AdmitsOnlyTheAllowList_EveryFunctionSubFunctionAndMeiType) {
  using A = GatewayAdmission::Action;
  const GatewayOptions open{}, read_only{.read_only = true};
  // A well-formed request for every function the codec reads.
  const std::map<uint8_t, std::vector<uint8_t>> valid = {
      {0x01, {0x01, 0, 0, 0, 1}},
      {0x02, {0x02, 0, 0, 0, 1}},
      {0x03, {0x03, 0, 0, 0, 1}},
      {0x04, {0x04, 0, 0, 0, 1}},
      {0x05, {0x05, 0, 0, 0xFF, 0x00}},
      {0x06, {0x06, 0, 0, 0, 1}},
      {0x07, {0x07}},
      {0x0B, {0x0B}},
      {0x0C, {0x0C}},
      {0x0F, {0x0F, 0, 0, 0, 1, 1, 1}},
      {0x10, {0x10, 0, 0, 0, 1, 2, 0, 5}},
      {0x11, {0x11}},
      {0x16, {0x16, 0, 0, 0xFF, 0xFF, 0, 0}},
      {0x17, {0x17, 0, 0, 0, 1, 0, 0, 0, 1, 2, 0, 5}},
  };
  for (unsigned f = 0; f <= 0xFF; ++f) {
    if (f == 0x08 || f == 0x2B) continue;  // below, by sub-function and MEI type
    const auto function = static_cast<uint8_t>(f);
    const auto it = valid.find(function);
    const std::vector<uint8_t> pdu =
        it != valid.end() ? it->second : std::vector<uint8_t>{function, 0, 0, 0, 1};
    const bool listed = (f >= 0x01 && f <= 0x04) || f == 0x0B || f == 0x0C || f == 0x11;
    const GatewayAdmission a = admit_gateway_request(read_only, 21, pdu, false);
    if (listed) {
      EXPECT_EQ(a.action, A::relay) << "FC" << std::hex << f;
    } else {
      EXPECT_EQ(a.action, A::refuse) << "FC" << std::hex << f;
      EXPECT_EQ(a.exception, Errc::illegal_function) << "FC" << std::hex << f;
    }
    // The same request on an open gateway: relayed if the codec reads it, so a refusal above is read-only's.
    if (it != valid.end()) EXPECT_EQ(admit_gateway_request(open, 21, pdu, false).action, A::relay);
    EXPECT_EQ(relays_when_read_only(Request{.function = function}), listed) << "FC" << std::hex << f;
  }
  for (uint32_t sub = 0; sub <= 0xFFFF; ++sub) {
    const std::vector<uint8_t> pdu = {0x08, static_cast<uint8_t>(sub >> 8), static_cast<uint8_t>(sub), 0, 0};
    const GatewayAdmission a = admit_gateway_request(read_only, 21, pdu, false);
    ASSERT_EQ(a.action, fc08_reads_only(static_cast<uint16_t>(sub)) ? A::relay : A::refuse)
        << "FC08 sub-function " << std::hex << sub;
    if (a.action == A::refuse) ASSERT_EQ(a.exception, Errc::illegal_function) << std::hex << sub;
    ASSERT_EQ(admit_gateway_request(open, 21, pdu, false).action, A::relay) << std::hex << sub;
  }
  for (unsigned mei = 0; mei <= 0xFF; ++mei) {
    const std::vector<uint8_t> pdu = {0x2B, static_cast<uint8_t>(mei), 0x01, 0x00};
    const GatewayAdmission a = admit_gateway_request(read_only, 21, pdu, false);
    EXPECT_EQ(a.action, mei == 0x0E ? A::relay : A::refuse) << "MEI type " << std::hex << mei;
    if (a.action == A::refuse) EXPECT_EQ(a.exception, Errc::illegal_function) << std::hex << mei;
    EXPECT_EQ(relays_when_read_only(Request{.function = 0x2B, .mei_type = static_cast<uint8_t>(mei)}),
              mei == 0x0E);
  }
}

// Every FC08 sub-function 0x00..0xFF through a running --read-only gateway:
// exactly 00 (echo), 02 (diagnostic register) and 0B..12 (the counters) reach
// the device and come back with its answer; every other one (01 restart, 03
// ASCII delimiter, 04 listen-only, 0A and 14 clears, 05..09, 13, 15 and up)
// is answered 01 by the gateway and never appears on the bus.
TEST_F(GatewayReadOnly, EveryDiagnosticSubFunction_OnlyEchoRegisterAndCountersReachTheBus) {
  std::vector<std::vector<uint8_t>> relayed;
  for (unsigned sub = 0; sub <= 0xFF; ++sub) {
    const std::vector<uint8_t> req =
        sub == 0x00 ? std::vector<uint8_t>{0x08, 0x00, 0x00, 0xAB, 0xCD}
                    : std::vector<uint8_t>{0x08, 0x00, static_cast<uint8_t>(sub), 0x00, 0x00};
    const std::vector<uint8_t> answer = ask(req);
    if (fc08_reads_only(static_cast<uint16_t>(sub))) {
      relayed.push_back(req);
      // The device's own answer: the echo, or the sub-function and its value.
      ASSERT_EQ(answer.size(), 5u) << "sub-function " << std::hex << sub;
      EXPECT_EQ(std::vector<uint8_t>(answer.begin(), answer.begin() + 3),
                std::vector<uint8_t>(req.begin(), req.begin() + 3));
      if (sub == 0x00) EXPECT_EQ(answer, req);
    } else {
      EXPECT_EQ(answer, (std::vector<uint8_t>{0x88, 0x01})) << "sub-function " << std::hex << sub;
    }
  }
  const std::vector<uint8_t> last = {0x03, 0x00, 0x42, 0x00, 0x01};
  ASSERT_EQ(ask(last).size(), 4u);
  relayed.push_back(last);
  // On the bus: the 10 relayed sub-functions and the last read, nothing else.
  EXPECT_EQ(bus_saw_after(last), relayed);
  // The device still answers (no listen-only, no restart reached it).
  EXPECT_EQ(ask({0x08, 0x00, 0x00, 0x12, 0x34}), (std::vector<uint8_t>{0x08, 0x00, 0x00, 0x12, 0x34}));
  ::kill(gateway_->pid(), SIGTERM);
  EXPECT_EQ(gateway_->wait(3000ms), 0);
  EXPECT_NE(gateway_->output().find("246 refused"), std::string::npos) << gateway_->output();
}

// The rest of the list: FC0B, FC0C, FC11 and FC2B/0E reach the device; FC2B
// with MEI type 0D (CANopen), FC17 (it writes), FC15 (write file record),
// FC14, FC07, FC18, the writes and a user-defined code get 01 from the
// gateway and never reach the bus.
TEST_F(GatewayReadOnly, IdentificationAndEventLogRelayed_WritesOtherMeiAndUnlistedRefused) {
  const std::vector<std::vector<uint8_t>> relay = {
      {0x0B},                    // get comm event counter
      {0x0C},                    // get comm event log
      {0x11},                    // report server id
      {0x2B, 0x0E, 0x01, 0x00},  // read device identification
  };
  const std::vector<std::vector<uint8_t>> refuse = {
      {0x2B, 0x0D, 0x00, 0x00},  // MEI 0D: CANopen general reference
      {0x17, 0x00, 0x05, 0x00, 0x01, 0x00, 0x05, 0x00, 0x01, 0x02, 0x12, 0x34},  // read/write multiple
      {0x15, 0x09, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00, 0x01, 0x12, 0x34},        // write file record
      {0x14, 0x07, 0x06, 0x00, 0x04, 0x00, 0x07, 0x00, 0x01},                    // read file record
      {0x07},                                                                    // read exception status
      {0x18, 0x00, 0x05},                                                        // read FIFO queue
      {0x05, 0x00, 0x05, 0xFF, 0x00},
      {0x06, 0x00, 0x05, 0x12, 0x34},
      {0x0F, 0x00, 0x05, 0x00, 0x01, 0x01, 0x01},
      {0x10, 0x00, 0x05, 0x00, 0x01, 0x02, 0x12, 0x34},
      {0x16, 0x00, 0x05, 0x00, 0x00, 0x12, 0x34},
      {0x41, 0x00, 0x05},  // user-defined
  };
  for (const auto& req : relay) {
    const std::vector<uint8_t> answer = ask(req);
    ASSERT_GE(answer.size(), 2u) << std::hex << int{req[0]};
    EXPECT_EQ(answer[0], req[0]);  // the device's answer, not an exception
    if (req[0] == 0x2B) EXPECT_EQ(answer[1], 0x0E);
  }
  for (const auto& req : refuse)
    EXPECT_EQ(ask(req), (std::vector<uint8_t>{static_cast<uint8_t>(req[0] | 0x80), 0x01}))
        << std::hex << int{req[0]};
  const std::vector<uint8_t> last = {0x03, 0x00, 0x05, 0x00, 0x01};
  EXPECT_EQ(ask(last), (std::vector<uint8_t>{0x03, 0x02, 0x00, 0x00}));  // nothing was written
  std::vector<std::vector<uint8_t>> want = relay;
  want.push_back(last);
  EXPECT_EQ(bus_saw_after(last), want);
}

// Quarantine (issue 28, item 6): a gateway in this process over a bus in
// memory. Unit 1 answers; unit 9 answers only while `alive_`. Every request
// the bus carried is logged by unit. Two virtual clocks: the master's (a
// timeout passes at once) and the gateway's (only the test moves it), so the
// back-off is exact and no assertion depends on this machine's speed.
class GatewayQuarantine : public ::testing::Test {
 protected:
  void SetUp() override {
    bank_.holding[5] = 111;
    bank9_.holding[5] = 999;
    ASSERT_TRUE(engine_.add_unit(UnitId{1}, bank_).ok());
    ASSERT_TRUE(engine_.add_unit(UnitId{9}, bank9_).ok());
    bus_ = std::make_unique<Master>(
        std::make_unique<MemoryLink>(bus_clock_, [this](std::span<const uint8_t> r) { return answer(r); }),
        MasterOptions{.response_timeout = 1000ms, .retries = 1, .clock = &bus_clock_});
    GatewayOptions o;
    o.quarantine_after = 3;
    o.probe_backoff = 1000ms;
    o.probe_backoff_max = 30000ms;
    o.clock = &gateway_clock_;
    o.on_quarantine = [this](const GatewayUnitEvent& e) {
      std::lock_guard lock(mutex_);
      events_.push_back(e);
    };
    const std::vector<io::PortSpec> listen = {*io::parse_port("tcp://127.0.0.1:0", true),
                                              *io::parse_port("rtu+tcp://127.0.0.1:0", true)};
    auto g = Gateway::start(ctx_, *bus_, listen, o);
    ASSERT_TRUE(g.ok()) << g.error().reason();
    gateway_ = std::move(*g);
    thread_ = std::thread([this] {
      auto work = asio::make_work_guard(ctx_);
      ctx_.run();
    });
  }
  void TearDown() override {
    if (!thread_.joinable()) return;
    asio::post(ctx_, [this] {
      gateway_.reset();
      ctx_.stop();
    });
    thread_.join();
  }

  MemoryLink::Reply answer(std::span<const uint8_t> request) {
    std::lock_guard lock(mutex_);
    seen_.push_back(request[0]);
    if (request[0] == 9 && !alive_) return {};
    std::array<uint8_t, kMaxRtuAduSize> out{};
    const size_t n = engine_.handle_rtu(request, out).length;
    return {{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 1ms};
  }
  // Requests to `unit` the bus carried (each retry counts).
  size_t seen(uint8_t unit) {
    std::lock_guard lock(mutex_);
    return static_cast<size_t>(std::count(seen_.begin(), seen_.end(), unit));
  }
  void set_alive(bool alive) {
    std::lock_guard lock(mutex_);
    alive_ = alive;
  }
  std::vector<GatewayUnitEvent> events() {
    std::lock_guard lock(mutex_);
    return events_;
  }
  // A client on the Modbus TCP (0) or RTU-over-TCP (1) listener; generous timeout.
  std::unique_ptr<Master> client(size_t listener = 0) {
    return std::make_unique<Master>(io::make_link(*io::parse_port(gateway_->where()[listener], false)),
                                    MasterOptions{.response_timeout = 10000ms});
  }
  Errc read(Master& m, uint8_t unit, uint16_t& v) {
    return m.read_holding_registers(UnitId{unit}, 5, {&v, 1}).code();
  }

  ManualClock bus_clock_, gateway_clock_;
  MemoryBank bank_{100}, bank9_{100};
  SlaveEngine engine_;
  std::mutex mutex_;  // seen_, alive_, events_
  std::vector<uint8_t> seen_;
  bool alive_ = false;
  std::vector<GatewayUnitEvent> events_;
  std::unique_ptr<Master> bus_;
  asio::io_context ctx_;
  std::unique_ptr<Gateway> gateway_;
  std::thread thread_;
};

// A unit that never answers is quarantined after 3 requests without an
// answer: from then on its requests get 0B from the gateway without reaching
// the bus, while unit 1 is served; once its back-off is over the next request
// is a probe (unanswered: the back-off doubles); when it answers again it is
// relayed again, without a restart.
TEST_F(GatewayQuarantine, DeadUnitGets0BAtOnce_LiveUnitServed_ServedAgainAfterItsBackOff) {
  auto live = client();
  auto dead = client();
  uint16_t v = 0;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
    ASSERT_EQ(read(*live, 1, v), Errc::ok);
    EXPECT_EQ(v, 111);
  }
  EXPECT_EQ(seen(9), 6u);  // 3 requests, each a timeout and a retry
  GatewayStats s = gateway_->stats();
  EXPECT_EQ(s.quarantined_units, std::vector<uint8_t>{9});
  EXPECT_EQ(s.quarantines, 1u);
  EXPECT_EQ(s.no_answer, 3u);
  const std::vector<GatewayUnitEvent> quarantined = events();
  EXPECT_EQ(quarantined.size(), 1u);
  if (quarantined.size() == 1) {
    EXPECT_EQ(quarantined[0].unit, 9);
    EXPECT_TRUE(quarantined[0].quarantined);
    EXPECT_EQ(quarantined[0].timeouts, 3u);
    EXPECT_EQ(quarantined[0].next_probe, 1000ms);
  }

  // Quarantined: the answer is exception 0B from the gateway, byte for byte,
  // and the bus carries nothing for unit 9; unit 1 is served meanwhile.
  const int fd = connect_to(gateway_->tcp_port());
  ASSERT_GE(fd, 0);
  const uint8_t request[] = {0x12, 0x34, 0, 0, 0, 6, 9, 0x03, 0x00, 0x05, 0x00, 0x01};
  ASSERT_EQ(::send(fd, request, sizeof request, MSG_NOSIGNAL), static_cast<ssize_t>(sizeof request));
  const std::vector<uint8_t> want = {0x12, 0x34, 0, 0, 0, 3, 9, 0x83, 0x0B};
  std::vector<uint8_t> got;
  ASSERT_TRUE(eventually([&] {
    uint8_t b[64];
    const ssize_t n = ::recv(fd, b, sizeof b, MSG_DONTWAIT);
    if (n > 0) got.insert(got.end(), b, b + n);
    return got.size() >= want.size();
  }));
  ::close(fd);
  EXPECT_EQ(got, want);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
    ASSERT_EQ(read(*live, 1, v), Errc::ok);
    EXPECT_EQ(v, 111);
  }
  // An RTU-over-TCP client gets it too, in the order of its requests.
  auto rtu = client(1);
  EXPECT_EQ(read(*rtu, 9, v), Errc::gateway_target_failed);
  ASSERT_EQ(read(*rtu, 1, v), Errc::ok);
  EXPECT_EQ(seen(9), 6u) << "a quarantined unit's request reached the bus";
  EXPECT_EQ(seen(1), 24u);
  s = gateway_->stats();
  EXPECT_EQ(s.quarantined_answers, 22u);
  EXPECT_EQ(s.probes, 0u);

  // After the back-off (1 s on the gateway's clock) one request is a probe;
  // unit 9 still does not answer, so the next probe waits 2 s.
  gateway_clock_.advance(999ms);
  EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
  EXPECT_EQ(seen(9), 6u);
  gateway_clock_.advance(1ms);
  EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
  EXPECT_EQ(seen(9), 8u);  // the probe: a timeout and a retry
  EXPECT_EQ(gateway_->stats().probes, 1u);
  EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
  gateway_clock_.advance(1999ms);
  EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);
  EXPECT_EQ(seen(9), 8u);

  // It answers again: served at its next probe, and relayed from then on.
  set_alive(true);
  EXPECT_EQ(read(*dead, 9, v), Errc::gateway_target_failed);  // its back-off is not over
  EXPECT_EQ(seen(9), 8u);
  gateway_clock_.advance(1ms);
  ASSERT_EQ(read(*dead, 9, v), Errc::ok);
  EXPECT_EQ(v, 999);
  ASSERT_EQ(read(*dead, 9, v), Errc::ok);
  EXPECT_EQ(seen(9), 10u);
  s = gateway_->stats();
  EXPECT_TRUE(s.quarantined_units.empty());
  EXPECT_EQ(s.probes, 2u);
  ASSERT_EQ(events().size(), 2u);
  EXPECT_EQ(events()[1].unit, 9);
  EXPECT_FALSE(events()[1].quarantined);
}

// The back-off doubles up to its ceiling; a unit that answers (even with its
// own exception) is never quarantined.
TEST_F(GatewayQuarantine, BackOffDoublesUpToItsCeiling_AnExceptionIsAnAnswer) {
  auto m = client();
  uint16_t v = 0;
  for (int i = 0; i < 5; ++i)  // unit 1 answers 02 (illegal address): an answer
    EXPECT_EQ(m->read_holding_registers(UnitId{1}, 500, {&v, 1}).code(), Errc::illegal_data_address);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(read(*m, 9, v), Errc::gateway_target_failed);
  EXPECT_EQ(gateway_->stats().quarantined_units, std::vector<uint8_t>{9});
  // Probes after 1, 2, 4, 8, 16, 30, 30 s: each a timeout and a retry on the bus.
  size_t on_bus = seen(9);
  for (const auto wait : {1000ms, 2000ms, 4000ms, 8000ms, 16000ms, 30000ms, 30000ms}) {
    gateway_clock_.advance(wait - 1ms);
    EXPECT_EQ(read(*m, 9, v), Errc::gateway_target_failed);
    EXPECT_EQ(seen(9), on_bus) << "a probe before " << wait.count() << " ms";
    gateway_clock_.advance(1ms);
    EXPECT_EQ(read(*m, 9, v), Errc::gateway_target_failed);
    EXPECT_EQ(seen(9), on_bus += 2) << "no probe after " << wait.count() << " ms";
  }
  EXPECT_EQ(gateway_->stats().quarantined_units, std::vector<uint8_t>{9});
  EXPECT_EQ(gateway_->stats().quarantines, 1u);
}

// The command line: --quarantine-after and the probe's back-off, a line on
// stderr when a unit is quarantined, and the counts in the exit line.
TEST_F(GatewayTest, QuarantineOnTheCommandLine) {
  start({"--quarantine-after", "2", "--probe-ms", "60000"});
  auto m = client();
  uint16_t v = 0;
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(m->read_holding_registers(UnitId{9}, 0, {&v, 1}).code(), Errc::gateway_target_failed);
  EXPECT_TRUE(m->read_holding_registers(UnitId{1}, 0, {&v, 1}).ok());
  EXPECT_TRUE(gateway_->wait_for_output("unit 9 quarantined after 2 requests")) << gateway_->output();
  ::kill(gateway_->pid(), SIGTERM);
  EXPECT_EQ(gateway_->wait(3000ms), 0);
  EXPECT_NE(gateway_->output().find("3 quarantined (0B at once), 0 probes, units quarantined: 9"),
            std::string::npos)
      << gateway_->output();
  // The bus carried the two requests that made it quarantined, no more.
  const std::string log = bus_->output();
  size_t to_9 = 0;
  for (size_t at = 0; (at = log.find("rx 09 03", at)) != std::string::npos; ++at) ++to_9;
  EXPECT_EQ(to_9, 2u) << log;
}
