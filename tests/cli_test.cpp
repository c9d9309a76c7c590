// The rtukit binary as users run it: outputs and exit codes
// (0 ok, 1 Modbus exception, 2 usage, 3 no response, 4 I/O error).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <thread>
#include <tuple>

#include "process.hpp"

using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

const std::string kRtukit = RTUKIT_BIN;

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    port_ = dir_ / "tty";
    std::ofstream(dir_ / "init.json") << R"({"holding": {"0x10": [1, 2, 65535], "20": [0, 16968, 0, 17096]},
                                           "input": {"0": 7}, "coils": {"3": 1},
                                           "identification": {"vendor": "ACME", "product_code": "M-3",
                                                              "revision": "2.1", "0x80": "test bench"}})";
    slave_ = std::make_unique<Process>(std::vector<std::string>{kRtukit, "slave", "--listen", "pty:" + port_,
                                                                "--unit", "5", "--registers", "100", "--init",
                                                                dir_ / "init.json"});
    ASSERT_TRUE(slave_->wait_for_output("listening on")) << slave_->output();
  }
  RunResult rtukit(std::vector<std::string> args) {
    args.insert(args.begin(), kRtukit);
    return run(args);
  }

  TempDir dir_;
  std::string port_;
  std::unique_ptr<Process> slave_;
};

}  // namespace

TEST_F(Cli, Read_PrintsAddressesAndValues) {
  const RunResult r = rtukit({"read", "--port", port_, "--unit", "5", "0x10", "3"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "16 (0x0010): 1\n17 (0x0011): 2\n18 (0x0012): 65535\n");
}

TEST_F(Cli, Read_Json_Hex_Signed_Float_WordOrder) {
  RunResult r = rtukit({"read", "--port", port_, "--unit", "5", "16", "3", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  // {"time": "...Z", "ok": true, ...} (docs/json.md)
  EXPECT_TRUE(r.output.starts_with(R"({"time":")")) << r.output;
  EXPECT_NE(r.output.find(
                R"(Z","ok":true,"unit":5,"table":"holding","address":16,"type":"u16","values":[1,2,65535]})"
                "\n"),
            std::string::npos)
      << r.output;
  r = rtukit({"read", "--port", port_, "--unit", "5", "18", "--type", "i16"});
  EXPECT_EQ(r.output, "18 (0x0012): -1\n");
  r = rtukit({"read", "--port", port_, "--unit", "5", "18", "--format", "hex"});
  EXPECT_EQ(r.output, "18 (0x0012): 0xFFFF\n");
  // 0x4248 0x0000 = 50.0f, high word first.
  r = rtukit({"read", "--port", port_, "--unit", "5", "21", "--type", "f32"});
  EXPECT_EQ(r.output, "21 (0x0015): 50.0\n");
  r = rtukit({"read", "--port", port_, "--unit", "5", "20", "2", "--type", "u32"});
  EXPECT_EQ(r.output, "20 (0x0014): 16968\n22 (0x0016): 17096\n");
  r = rtukit({"read", "--port", port_, "--unit", "5", "22", "--type", "u32", "--word-order", "low-first"});
  EXPECT_EQ(r.output, "22 (0x0016): 1120403456\n");  // 0x42C80000
}

TEST_F(Cli, ReadOtherTables) {
  RunResult r = rtukit({"read", "--port", port_, "--unit", "5", "--input", "0"});
  EXPECT_EQ(r.output, "0 (0x0000): 7\n");
  r = rtukit({"read", "--port", port_, "--unit", "5", "--coils", "2", "3"});
  EXPECT_EQ(r.output, "2 (0x0002): 0\n3 (0x0003): 1\n4 (0x0004): 0\n");
  r = rtukit({"read", "--port", port_, "--unit", "5", "--discrete", "0"});
  EXPECT_EQ(r.code, 0);
}

TEST_F(Cli, Write_SingleMultipleAndCoils) {
  ASSERT_EQ(rtukit({"write", "--port", port_, "--unit", "5", "30", "0x2A"}).code, 0);
  ASSERT_EQ(rtukit({"write", "--port", port_, "--unit", "5", "31", "5", "6"}).code, 0);
  ASSERT_EQ(rtukit({"write", "--port", port_, "--unit", "5", "33", "-2", "--type", "i16", "--multiple"}).code,
            0);
  ASSERT_EQ(rtukit({"write", "--port", port_, "--unit", "5", "--coils", "7", "1", "1"}).code, 0);
  EXPECT_NE(
      rtukit({"read", "--port", port_, "--unit", "5", "30", "4", "--json"})
          .output.find(R"("unit":5,"table":"holding","address":30,"type":"u16","values":[42,5,6,65534]})"),
      std::string::npos);
  const RunResult w = rtukit({"write", "--port", port_, "--unit", "5", "40", "7", "--json"});
  EXPECT_EQ(w.code, 0) << w.output;
  EXPECT_NE(w.output.find(R"("ok":true,"unit":5,"table":"holding","address":40,"written":1,)"
                          R"("text":"wrote 7 to holding register 40 (0x0028) of unit 5"})"),
            std::string::npos)
      << w.output;
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "--coils", "7", "2"}).output,
            "7 (0x0007): 1\n8 (0x0008): 1\n");
  // The slave logged FC06, FC10 (and FC10 for the --multiple single value), FC0F.
  EXPECT_TRUE(eventually([&] { return !slave_->output().empty(); }));
}

// A write says what it wrote, in one line, with the address as it was typed
// and the address on the wire (issue 28); --quiet says nothing.
TEST_F(Cli, Write_SaysWhatWasWritten) {
  RunResult r = rtukit({"write", "--port", port_, "--unit", "5", "30", "0x2A"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "wrote 0x2A to holding register 30 (0x001E) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "31", "5", "6"});
  EXPECT_EQ(r.output, "wrote 5, 6 to holding registers 31..32 (0x001F..0x0020) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "33", "-2", "--type", "i16"});
  EXPECT_EQ(r.output, "wrote -2 (i16) to holding register 33 (0x0021) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "34", "1.5", "--type", "f32"});
  EXPECT_EQ(r.output, "wrote 1.5 (f32) to holding registers 34..35 (0x0022..0x0023) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "--coils", "7", "1"});
  EXPECT_EQ(r.output, "wrote 1 to coil 7 (0x0007) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "--coils", "7", "1", "0"});
  EXPECT_EQ(r.output, "wrote 1, 0 to coils 7..8 (0x0007..0x0008) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "--mask", "0x00F2", "0x0025", "50"});
  EXPECT_EQ(r.output, "masked holding register 50 (0x0032) of unit 5 with AND 0x00F2 OR 0x0025\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "--one-based", "31", "9"});
  EXPECT_EQ(r.output, "wrote 9 to holding register 31 (0x001E) of unit 5\n");
  r = rtukit(
      {"write", "--port", port_, "--unit", "5", "0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "10"});
  EXPECT_EQ(r.output,
            "wrote 1, 2, 3, 4, ..., 10 (10 values) to holding registers 0..9 (0x0000..0x0009) of unit 5\n");
  r = rtukit({"write", "--port", port_, "--unit", "5", "30", "7", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "");
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "30", "2"}).output,
            "30 (0x001E): 7\n31 (0x001F): 5\n");
}

// A value its type cannot hold is a usage error (exit 2), found before the
// port is opened: here the port does not exist, and the refusal is still
// about the value (issue 28).
TEST_F(Cli, Write_UnencodableValue_Exit2_BeforeThePortOpens) {
  const std::string missing = dir_ / "missing";
  for (const auto& [value, type, message] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"1e50", "f32",
            "rtukit: f32 value 1e50 is out of range (at most 3.4028235e+38 either side of 0)\n"},
           {"-1e39", "f32",
            "rtukit: f32 value -1e39 is out of range (at most 3.4028235e+38 either side of 0)\n"},
           {"nan", "f32", "rtukit: f32 value nan is not a finite number\n"},
           {"1e-50", "f32", "rtukit: f32 value 1e-50 is too small for f32: it would be written as 0\n"},
           {"40000", "i16",
            "rtukit: i16 value 40000 is out of range -32768..32767 (or 0x0000..0xFFFF in hex, the raw "
            "bits)\n"},
           {"-32769", "i16",
            "rtukit: i16 value -32769 is out of range -32768..32767 (or 0x0000..0xFFFF in hex, the raw "
            "bits)\n"},
           {"70000", "u16", "rtukit: u16 value 70000 is out of range 0..65535\n"},
           {"4294967296", "u32", "rtukit: u32 value 4294967296 is out of range 0..4294967295\n"},
           {"2147483648", "i32",
            "rtukit: i32 value 2147483648 is out of range -2147483648..2147483647 (or 0x00000000..0xFFFFFFFF "
            "in hex, the raw bits)\n"}}) {
    const RunResult r = rtukit({"write", "--port", missing, "0", "--type", type, "--", value});
    EXPECT_EQ(r.code, 2) << value << " " << type << ": " << r.output;
    EXPECT_EQ(r.output, message);
  }
  // A coil value or a mask, likewise.
  EXPECT_EQ(rtukit({"write", "--port", missing, "--coils", "0", "2"}).code, 2);
  EXPECT_EQ(rtukit({"write", "--port", missing, "--mask", "0x10000", "0", "5"}).code, 2);
  // Values that fit get as far as the port: hex gives an i16 its raw bits.
  RunResult r = rtukit({"write", "--port", missing, "0", "--type", "i16", "0xFFFF"});
  EXPECT_EQ(r.code, 4) << r.output;
  r = rtukit({"write", "--port", missing, "0", "--type", "f32", "3.4e38"});
  EXPECT_EQ(r.code, 4) << r.output;
}

// FC16 and FC17 (issue 14) from the command line.
TEST_F(Cli, MaskWriteAndReadWrite) {
  ASSERT_EQ(rtukit({"write", "--port", port_, "--unit", "5", "50", "0x12"}).code, 0);
  RunResult r = rtukit({"write", "--port", port_, "--unit", "5", "--mask", "0x00F2", "0x0025", "50"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "50"}).output, "50 (0x0032): 23\n");  // 0x17
  r = rtukit({"readwrite", "--port", port_, "--unit", "5", "59", "3", "60", "7", "8"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "59 (0x003B): 0\n60 (0x003C): 7\n61 (0x003D): 8\n");  // the write came first
  r = rtukit({"readwrite", "--port", port_, "--unit", "5", "--json", "60", "1", "60", "9"});
  EXPECT_NE(r.output.find(R"("written":{"address":60,"count":1},"address":60,"values":[9]})"),
            std::string::npos)
      << r.output;
  // The slave's exception, named with the request; usage errors in one line.
  r = rtukit({"readwrite", "--port", port_, "--unit", "5", "98", "5", "0", "1"});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("FC17 read/write multiple registers"), std::string::npos) << r.output;
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "0"}).output,
            "0 (0x0000): 0\n");  // nothing written
  r = rtukit({"write", "--port", port_, "--unit", "5", "--mask", "1", "2", "50", "7"});
  EXPECT_EQ(r.code, 2) << r.output;
  r = rtukit({"readwrite", "--port", port_, "--unit", "0", "1", "1", "1", "1"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("cannot be broadcast"), std::string::npos) << r.output;
}

// Diagnostics and identification (issue 14): counters that match what was
// injected on the line, the event log, echo, listen-only and restart.
TEST_F(Cli, DiagAndIdent) {
  ASSERT_EQ(rtukit({"diag", "--port", port_, "--unit", "5", "clear"}).code, 0);
  // Two frames with a bad CRC and one exception, straight onto the line.
  {
    const int fd = ::open(port_.c_str(), O_RDWR | O_NOCTTY);
    ASSERT_GE(fd, 0);
    const uint8_t bad[] = {0x05, 0x03, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00};
    ASSERT_EQ(::write(fd, bad, sizeof bad), static_cast<ssize_t>(sizeof bad));
    std::this_thread::sleep_for(50ms);  // a silence between them, as on a line
    ASSERT_EQ(::write(fd, bad, sizeof bad), static_cast<ssize_t>(sizeof bad));
    std::this_thread::sleep_for(50ms);
    ::close(fd);
  }
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "99", "2"}).code, 1);
  RunResult r = rtukit({"diag", "--port", port_, "--unit", "5", "--json"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find(R"("bus_crc_errors":2,"bus_exceptions":1)"), std::string::npos) << r.output;
  r = rtukit({"diag", "--port", port_, "--unit", "5", "echo", "0x12", "0x34"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("echo ok: 12 34"), std::string::npos) << r.output;
  r = rtukit({"diag", "--port", port_, "--unit", "5", "events"});
  EXPECT_NE(r.output.find("received, communication error"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("sent, read exception"), std::string::npos) << r.output;
  // Listen-only: silent until restart.
  ASSERT_EQ(rtukit({"diag", "--port", port_, "--unit", "5", "listen-only"}).code, 0);
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "0x10", "--timeout", "200"}).code, 3);
  r = rtukit({"diag", "--port", port_, "--unit", "5", "restart", "--timeout", "200"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(rtukit({"read", "--port", port_, "--unit", "5", "0x10"}).output, "16 (0x0010): 1\n");
  // Identification from --init, one object, FC11.
  r = rtukit({"ident", "--port", port_, "--unit", "5", "--level", "extended"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("vendor        ACME"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0x80          test bench"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(conformity: extended, individual access)"), std::string::npos) << r.output;
  r = rtukit({"ident", "--port", port_, "--unit", "5", "--object", "1", "--json"});
  EXPECT_NE(r.output.find(R"("objects":{"product code":"M-3"}})"), std::string::npos) << r.output;
  r = rtukit({"ident", "--port", port_, "--unit", "5", "--object", "7"});
  EXPECT_EQ(r.code, 1) << r.output;  // 02: no such object
  r = rtukit({"ident", "--port", port_, "--unit", "5", "--server-id"});
  EXPECT_EQ(r.output, "server id 5, running\nACME M-3 2.1\n");
}

TEST_F(Cli, ModbusException_Exit1_NamesTheException) {
  const RunResult r = rtukit({"read", "--port", port_, "--unit", "5", "99", "2"});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("Modbus exception 02 (illegal data address)"), std::string::npos) << r.output;
}

TEST_F(Cli, UsageErrors_Exit2_OneLine) {
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"read", "--port", port_, "--unit", "5", "0", "126"},
           {"read", "--port", port_, "--unit", "5", "0x1G"},
           {"read", "--port", port_, "--unit", "300", "0"},
           {"read", "--port", port_, "--unit", "248", "0"},  // RTU unicast is 1..247
           {"slave", "--listen", "pty", "--unit", "0"},
           {"read", "--port", port_, "0", "--type", "u64"},
           {"write", "--port", port_, "0", "70000"},
           {"read", "--port", "udp://x:1", "0"},
           {"read", "--port", port_, "--baud", "5", "0"},
           {"read", "--port", port_, "--timeout", "0", "0"},  // never waiting is no timeout
           {"frobnicate"},
           {}}) {
    const RunResult r = rtukit(args);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
}

TEST_F(Cli, NoResponse_Exit3) {
  const RunResult r = rtukit({"read", "--port", port_, "--unit", "6", "0", "--timeout", "100"});
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.output.find("no response"), std::string::npos) << r.output;
}

TEST_F(Cli, IoError_Exit4) {
  RunResult r = rtukit({"read", "--port", dir_ / "missing", "0"});
  EXPECT_EQ(r.code, 4);
  EXPECT_NE(r.output.find("No such file or directory"), std::string::npos) << r.output;
  r = rtukit({"read", "--port", "tcp://127.0.0.1:" + std::to_string(free_tcp_port()), "0"});
  EXPECT_EQ(r.code, 4);
  EXPECT_NE(r.output.find("Connection refused"), std::string::npos) << r.output;
}

// A port that is not a serial port (a regular file, /dev/null) is said in
// words, not as "Inappropriate ioctl for device" (issue 28).
TEST_F(Cli, NotASerialPort_SaysSo_Exit4) {
  const std::string file = dir_ / "file";
  std::ofstream(file) << "x";
  for (const std::string& path : {file, std::string("/dev/null")}) {
    const RunResult r = rtukit({"read", "--port", path, "0"});
    EXPECT_EQ(r.code, 4) << r.output;
    EXPECT_NE(r.output.find(": " + path +
                            " is not a serial port (give /dev/ttyUSB0, /dev/ttyS0 or a pty, or "
                            "tcp://HOST:PORT)\n"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("Inappropriate ioctl"), std::string::npos) << r.output;
  }
  const RunResult r = rtukit({"rehand6600", "status", "--port", file});
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_NE(r.output.find(file + " is not a serial port"), std::string::npos) << r.output;
}

TEST_F(Cli, Scan_FindsTheUnit) {
  const RunResult r = rtukit({"scan", "--port", port_, "--units", "3-7", "--timeout", "50"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "unit 5 answers\n");
  const RunResult none = rtukit({"scan", "--port", port_, "--units", "1-2", "--timeout", "50"});
  EXPECT_EQ(none.code, 3);
}

TEST_F(Cli, Stats_PrintsCounters) {
  const RunResult r = rtukit({"read", "--port", port_, "--unit", "5", "0", "--stats"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("stats: requests=1 responses=1 exceptions=0 timeouts=0"), std::string::npos)
      << r.output;
}

TEST(CliSlave, BadInitFile_Exit2_AndBusyPort_Exit4) {
  TempDir dir;
  std::ofstream(dir / "bad.json") << "{ not json";
  RunResult r = run({kRtukit, "slave", "--listen", "pty", "--init", dir / "bad.json"});
  EXPECT_EQ(r.code, 2) << r.output;
  const uint16_t port = free_tcp_port();
  Process first({kRtukit, "slave", "--listen", "tcp://127.0.0.1:" + std::to_string(port)});
  ASSERT_TRUE(first.wait_for_output("listening on"));
  r = run({kRtukit, "slave", "--listen", "tcp://127.0.0.1:" + std::to_string(port)});
  EXPECT_EQ(r.code, 4) << r.output;
}

// `--any-unit` (issue 14): over Modbus TCP every unit id reaches the first
// unit; without it another id is not answered; on a serial line it is refused.
TEST(CliSlave, AnyUnitOverTcp) {
  const uint16_t port = free_tcp_port();
  const std::string where = "tcp://127.0.0.1:" + std::to_string(port);
  {
    Process plain({kRtukit, "slave", "--listen", where, "--unit", "5"});
    ASSERT_TRUE(plain.wait_for_output("listening on")) << plain.output();
    EXPECT_EQ(run({kRtukit, "read", "--port", where, "--unit", "9", "0", "--timeout", "300"}).code, 3);
    plain.stop();
  }
  Process any({kRtukit, "slave", "--listen", where, "--unit", "5", "--any-unit"});
  ASSERT_TRUE(any.wait_for_output("listening on")) << any.output();
  ASSERT_EQ(run({kRtukit, "write", "--port", where, "--unit", "9", "3", "77"}).code, 0);
  EXPECT_EQ(run({kRtukit, "read", "--port", where, "--unit", "5", "3"}).output, "3 (0x0003): 77\n");
  TempDir dir;
  const RunResult serial = run({kRtukit, "slave", "--listen", "pty:" + (dir / "tty"), "--any-unit"});
  EXPECT_EQ(serial.code, 2) << serial.output;
  EXPECT_NE(serial.output.find("--any-unit is for Modbus TCP"), std::string::npos) << serial.output;
}
