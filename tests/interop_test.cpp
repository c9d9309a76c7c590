// Interop with real peers we did not write, from Debian: libmodbus, pymodbus
// and mbpoll. Over a socat pty pair (RTU) and TCP loopback (Modbus TCP).
// Each test starts what it needs and stops it by PID.
#include <gtest/gtest.h>

#include "process.hpp"
#include "rtukit/driver/master.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

const std::string kRtukit = RTUKIT_BIN;
const std::string kLibmodbusServer = LIBMODBUS_SERVER_BIN;
const std::string kLibmodbusClient = LIBMODBUS_CLIENT_BIN;
const std::string kPeers = PEERS_DIR;
const std::string kPython = "/usr/bin/python3";  // Debian's, which has pymodbus

std::unique_ptr<Master> master_for(const std::string& port) {
  Result<io::PortSpec> spec = io::parse_port(port, false);
  EXPECT_TRUE(spec.ok()) << spec.error().text();
  MasterOptions o;
  o.response_timeout = 1000ms;
  o.retries = 1;
  return std::make_unique<Master>(io::make_link(*spec), o);
}

// Our master against a server holding holding[i] = 10 i, input[i] = 1000 + i,
// coil[i] = i % 2 (libmodbus_server and pymodbus_server agree on this).
void exercise_server(Master& m) {
  const UnitId unit{1};
  // The server may still be starting: allow a few attempts for the first read.
  std::array<uint16_t, 4> regs{};
  ASSERT_TRUE(eventually([&] { return m.read_holding_registers(unit, 2, regs).ok(); }, 10000ms));
  EXPECT_EQ(regs, (std::array<uint16_t, 4>{20, 30, 40, 50}));

  std::array<uint16_t, 125> max{};
  ASSERT_TRUE(m.read_holding_registers(unit, 0, max).ok());
  EXPECT_EQ(max[124], 1240);

  uint16_t in = 0;
  ASSERT_TRUE(m.read_input_registers(unit, 7, {&in, 1}).ok());
  EXPECT_EQ(in, 1007);

  const uint16_t values[] = {11, 22, 33};
  ASSERT_TRUE(m.write_multiple_registers(unit, 40, values).ok());
  ASSERT_TRUE(m.write_single_register(unit, 43, 44).ok());
  ASSERT_TRUE(m.read_holding_registers(unit, 40, regs).ok());
  EXPECT_EQ(regs, (std::array<uint16_t, 4>{11, 22, 33, 44}));

  std::array<uint8_t, 4> coils{};
  ASSERT_TRUE(m.read_coils(unit, 0, coils).ok());
  EXPECT_EQ(coils, (std::array<uint8_t, 4>{0, 1, 0, 1}));
  ASSERT_TRUE(m.write_single_coil(unit, 0, true).ok());
  const uint8_t bits[] = {1, 1, 0};
  ASSERT_TRUE(m.write_multiple_coils(unit, 10, bits).ok());
  std::array<uint8_t, 3> back{};
  ASSERT_TRUE(m.read_coils(unit, 10, back).ok());
  EXPECT_EQ(back, (std::array<uint8_t, 3>{1, 1, 0}));

  std::array<uint16_t, 10> past{};
  const Error e = m.read_holding_registers(unit, 195, past);
  EXPECT_EQ(e.code(), Errc::illegal_data_address) << e.name();

  // FC16 and FC17 (issue 14): holding[60] = 600 on both servers.
  uint16_t v = 0;
  ASSERT_TRUE(m.mask_write_register(unit, 60, 0x00F2, 0x0025).ok());
  ASSERT_TRUE(m.read_holding_registers(unit, 60, {&v, 1}).ok());
  EXPECT_EQ(v, (600 & 0x00F2) | (0x0025 & ~0x00F2));
  const uint16_t rw[] = {7, 8};
  std::array<uint16_t, 3> after{};
  ASSERT_TRUE(m.read_write_multiple_registers(unit, 69, after, 70, rw).ok());
  EXPECT_EQ(after, (std::array<uint16_t, 3>{690, 7, 8}));  // the write came first
}

}  // namespace

// ---- our master against their servers ----

// FC11 against libmodbus's server: its slave id, "on", then "LMB" and its version.
void report_server_id_of_libmodbus(Master& m) {
  std::vector<uint8_t> data;
  ASSERT_TRUE(m.report_server_id(UnitId{1}, data).ok());
  ASSERT_GE(data.size(), 5u);
  EXPECT_EQ(data[1], 0xFF);
  EXPECT_EQ(std::string(data.begin() + 2, data.begin() + 5), "LMB");
}

// FC08 and FC2B/0E against pymodbus's server.
void diagnostics_of_pymodbus(Master& m) {
  const uint8_t echo[] = {0xA5, 0x37};
  std::vector<uint8_t> answer;
  ASSERT_TRUE(m.diagnostics(UnitId{1}, Diagnostic::return_query_data, echo, answer).ok());
  EXPECT_EQ(answer, (std::vector<uint8_t>{0xA5, 0x37}));
  uint16_t messages = 0;
  ASSERT_TRUE(m.diagnostic_value(UnitId{1}, Diagnostic::bus_message_count, messages).ok());
  Master::DeviceIdentification id;
  ASSERT_TRUE(m.read_device_identification(UnitId{1}, DeviceIdAccess::basic, id).ok());
  EXPECT_EQ(id.objects[0], "pymodbus");
  EXPECT_EQ(id.objects[1], "PM");
  EXPECT_EQ(id.objects[2], "3.0");
}

TEST(Interop, OurMaster_LibmodbusServer_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  Process server({kLibmodbusServer, "rtu", pair.a()});
  ASSERT_TRUE(server.wait_for_output("ready")) << server.output();
  auto m = master_for(pair.b());
  exercise_server(*m);
  report_server_id_of_libmodbus(*m);
}

TEST(Interop, OurMaster_LibmodbusServer_Tcp) {
  const uint16_t port = free_tcp_port();
  Process server({kLibmodbusServer, "tcp", std::to_string(port)});
  ASSERT_TRUE(server.wait_for_output("ready")) << server.output();
  auto m = master_for("tcp://127.0.0.1:" + std::to_string(port));
  exercise_server(*m);
  report_server_id_of_libmodbus(*m);
}

TEST(Interop, OurMaster_PymodbusServer_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  Process server({kPython, kPeers + "/pymodbus_server.py", "rtu", pair.a()});
  ASSERT_TRUE(server.wait_for_output("ready")) << server.output();
  auto m = master_for(pair.b());
  exercise_server(*m);
  diagnostics_of_pymodbus(*m);
}

TEST(Interop, OurMaster_PymodbusServer_Tcp) {
  const uint16_t port = free_tcp_port();
  Process server({kPython, kPeers + "/pymodbus_server.py", "tcp", std::to_string(port)});
  ASSERT_TRUE(server.wait_for_output("ready")) << server.output();
  auto m = master_for("tcp://127.0.0.1:" + std::to_string(port));
  exercise_server(*m);
  diagnostics_of_pymodbus(*m);
}

// ---- their clients against our slave (the rtukit binary) ----

namespace {

// Our generic slave, started as users start it, listening on `listen`.
std::unique_ptr<Process> start_our_slave(const std::string& listen) {
  auto p = std::make_unique<Process>(
      std::vector<std::string>{kRtukit, "slave", "--listen", listen, "--unit", "1", "--registers", "1000"});
  EXPECT_TRUE(p->wait_for_output("listening on")) << p->output();
  return p;
}

}  // namespace

TEST(Interop, LibmodbusClient_OurSlave_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  auto slave = start_our_slave(pair.a());
  const RunResult r = run({kLibmodbusClient, "rtu", pair.b()});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos);
}

TEST(Interop, LibmodbusClient_OurSlave_Tcp) {
  const uint16_t port = free_tcp_port();
  auto slave = start_our_slave("tcp://127.0.0.1:" + std::to_string(port));
  const RunResult r = run({kLibmodbusClient, "tcp", std::to_string(port)});
  EXPECT_EQ(r.code, 0) << r.output;
}

// pymodbus's diagnostic, identification and report-server-id requests (issue 14).
TEST(Interop, PymodbusDiagnostics_OurSlave_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  auto slave = start_our_slave(pair.a());
  const RunResult r = run({kPython, kPeers + "/pymodbus_diag.py", "rtu", pair.b()}, 60000ms);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST(Interop, PymodbusDiagnostics_OurSlave_Tcp) {
  const uint16_t port = free_tcp_port();
  auto slave = start_our_slave("tcp://127.0.0.1:" + std::to_string(port));
  const RunResult r = run({kPython, kPeers + "/pymodbus_diag.py", "tcp", std::to_string(port)});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST(Interop, PymodbusClient_OurSlave_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  auto slave = start_our_slave(pair.a());
  const RunResult r = run({kPython, kPeers + "/pymodbus_client.py", "rtu", pair.b()});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos);
}

TEST(Interop, PymodbusClient_OurSlave_Tcp) {
  const uint16_t port = free_tcp_port();
  auto slave = start_our_slave("tcp://127.0.0.1:" + std::to_string(port));
  const RunResult r = run({kPython, kPeers + "/pymodbus_client.py", "tcp", std::to_string(port)});
  EXPECT_EQ(r.code, 0) << r.output;
}

TEST(Interop, Mbpoll_OurSlave_RtuOverSocatPty) {
  TempDir dir;
  PtyPair pair(dir);
  ASSERT_TRUE(pair.ready());
  auto slave = start_our_slave(pair.a());
  const std::vector<std::string> rtu = {"mbpoll", "-m", "rtu",  "-a", "1", "-b",
                                        "9600",   "-P", "none", "-0", "-1"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> v = rtu;
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
  };
  RunResult w = run(with({"-r", "7", pair.b(), "4321", "1234"}));
  ASSERT_EQ(w.code, 0) << w.output;
  RunResult r = run(with({"-r", "7", "-c", "2", pair.b()}));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("[7]: \t4321"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[8]: \t1234"), std::string::npos) << r.output;
  RunResult bad = run(with({"-r", "990", "-c", "20", pair.b()}));  // past our 1000 registers
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("Illegal data address"), std::string::npos) << bad.output;
}

TEST(Interop, Mbpoll_OurSlave_Tcp) {
  const uint16_t port = free_tcp_port();
  auto slave = start_our_slave("tcp://127.0.0.1:" + std::to_string(port));
  const std::vector<std::string> tcp = {"mbpoll", "-m", "tcp", "-p", std::to_string(port),
                                        "-a",     "1",  "-0",  "-1"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> v = tcp;
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
  };
  RunResult w = run(with({"-r", "3", "127.0.0.1", "555"}));
  ASSERT_EQ(w.code, 0) << w.output;
  RunResult r = run(with({"-r", "3", "127.0.0.1"}));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("[3]: \t555"), std::string::npos) << r.output;
  RunResult coil = run(with({"-t", "0", "-r", "9", "127.0.0.1", "1"}));
  ASSERT_EQ(coil.code, 0) << coil.output;
  RunResult coils = run(with({"-t", "0", "-r", "9", "127.0.0.1"}));
  EXPECT_NE(coils.output.find("[9]: \t1"), std::string::npos) << coils.output;
}
