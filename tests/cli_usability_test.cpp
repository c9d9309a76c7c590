// The CLI as a new user meets it: mistyped commands and options get the
// closest match, failures say what to check, addresses can be typed as other
// tools show them, and help, version and completion come from the binary.
// Exact messages and exit codes, as users (and their scripts) see them.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "process.hpp"

using namespace rtukit::test;

namespace {

const std::string kBin = RTUKIT_BIN;

RunResult rtukit(std::vector<std::string> args) {
  args.insert(args.begin(), kBin);
  return run(args);
}

// A generic slave on a pty for the tests that need an answer.
struct Slave {
  explicit Slave(const TempDir& dir)
      : tty(dir / "tty"),
        process({kBin, "slave", "--listen", "pty:" + tty, "--unit", "1", "--registers", "100"}) {}
  std::string tty;
  Process process;
  bool ready() {
    return eventually([&] { return path_exists(tty); });
  }
};

#ifdef RTUKIT_EXAMPLE_DEVICE
#define kExampleDevice "thermostat, "  // the registered example device's command
#else
#define kExampleDevice ""
#endif

TEST(CliUsability, UnknownCommandsSuggestTheClosest) {
  RunResult r = rtukit({"raed"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output,
            "rtukit: unknown command 'raed' (did you mean 'read'?) (commands: read, poll, write, readwrite, "
            "scan, slave, diag, ident, "
            "inverjet, rehand6600, devices, " kExampleDevice
            "map, sim, gateway, bus, relay, sniff, doctor, completion, manpage)\n");
  r = rtukit({"inverjet", "stat"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("rtukit: unknown command 'stat' for 'rtukit inverjet' (did you mean 'status'?)"),
            std::string::npos)
      << r.output;
  r = rtukit({"sim", "invrejet"});
  EXPECT_NE(r.output.find("(did you mean 'inverjet'?)"), std::string::npos) << r.output;
}

TEST(CliUsability, UnknownOptionsSuggestTheClosest) {
  RunResult r = rtukit({"read", "--prot", "/dev/ttyUSB0", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output,
            "rtukit: unknown option '--prot' for 'rtukit read' (did you mean '--port'?) (see rtukit read "
            "--help)\n");
}

// Issue 38: mbpoll's options (-a, -r, -t 4, a bare device) got CLI11's
// generic "not expected" with no pointer to what rtukit calls them. The
// failing line says, for each, what it is here, and names the mapping's doc.
TEST(CliUsability, MbpollOptionsSayWhatTheyAreHere) {
  RunResult r = rtukit({"read", "-a", "21", "-r", "34", "-c", "4", "/dev/ttyUSB0"});
  EXPECT_EQ(r.code, 2) << r.output;
  for (const char* says : {"mbpoll's -a 21 is --unit 21",
                           "-r 34 is the address after the command, counted from 0 "
                           "(or --one-based 34)",
                           "-c 4 is the count after the address", "the device is --port /dev/ttyUSB0",
                           " here (docs/coming-from-mbpoll.md)\n"})
    EXPECT_NE(r.output.find(says), std::string::npos) << says << "\n" << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "-t", "4", "0", "2"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("mbpoll's -t 4 is --holding here"), std::string::npos) << r.output;
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "-t", "3:float", "0", "2"});
  EXPECT_NE(r.output.find("mbpoll's -t 3:float is --input with --type u16|i16|u32|i32|f32 here"),
            std::string::npos)
      << r.output;
  // A mistake that is not mbpoll's gets no such hint.
  r = rtukit({"read", "--port", "/dev/ttyUSB0"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(r.output.find("mbpoll"), std::string::npos) << r.output;
}

TEST(CliUsability, HelpForACommand) {
  RunResult r = rtukit({"help", "read"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.output.find("Usage: rtukit read"), std::string::npos) << r.output;
  // The command's own options come before the link options.
  EXPECT_LT(r.output.find("--one-based"), r.output.find("Link options")) << r.output;
  EXPECT_NE(r.output.find("--parity TEXT=N             none, even or odd (N, E, O)"), std::string::npos);
  r = rtukit({"help", "raed"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("did you mean 'read'?"), std::string::npos);
}

TEST(CliUsability, PortsWithoutSchemeAndBroadcastReads) {
  RunResult r = rtukit({"read", "--port", "127.0.0.1:1502", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output,
            "rtukit: bad port '127.0.0.1:1502': did you mean tcp://127.0.0.1:1502 (Modbus TCP) or "
            "rtu+tcp://127.0.0.1:1502?\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "--unit", "0", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output,
            "rtukit: unit 0 is the broadcast address: nobody answers a broadcast, so it cannot be read (name "
            "a unit "
            "1..247)\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "--parity", "evn", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output, "rtukit: --parity 'evn' is not one of none, even, odd (or N, E, O)\n");
  r = rtukit({"read", "--port", "tcp://no-such-host.invalid:1502", "1"});
  EXPECT_EQ(r.code, 4);
  EXPECT_NE(r.output.find("cannot resolve the host name"), std::string::npos) << r.output;
}

TEST(CliUsability, FailuresNameTheRequestAndWhatToCheck) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  RunResult r = rtukit({"read", "--port", slave.tty, "200", "2"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.output, "rtukit: FC03 read holding registers at 200 (0x00C8) x2 from unit 1 on " + slave.tty +
                          " 9600 8N1: Modbus exception 02 (illegal data address)\n");
  r = rtukit({"read", "--port", slave.tty, "--unit", "9", "--timeout", "100", "--parity", "even", "1"});
  EXPECT_EQ(r.code, 3);
  EXPECT_EQ(
      r.output,
      "rtukit: FC03 read holding registers at 1 (0x0001) x1 from unit 9 on " + slave.tty +
          " 9600 8E1: no response (timeout). Check the unit address, the baud rate and parity, and the A/B "
          "wiring; `rtukit scan` lists the units that answer\n");
}

TEST(CliUsability, ScanTakesListsAndHonoursTimeout) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  RunResult r = rtukit({"scan", "--port", slave.tty, "--units", "3,1,5-6", "--timeout", "150", "--json"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("\"ok\":true,\"units\":[1]}\n"), std::string::npos) << r.output;
  r = rtukit({"scan", "--port", slave.tty, "--units", "7", "--timeout", "250"});
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.output.find("no unit of 7 answered (timeout 250 ms"), std::string::npos) << r.output;
}

// Long waits speak (issue 28): on a terminal (a pty from `script`) the scan
// shows how far it is and what it found, the doctor each step as it runs; in
// a pipe neither prints anything extra. `scan --json` prints one document
// even when nothing answers, and its help gives the timeout it really uses.
TEST(CliUsability, ScanAndDoctorShowProgressOnATerminalOnly) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  RunResult r = rtukit({"scan", "--port", slave.tty, "--units", "1-3"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output, "unit 1 answers\n");  // a pipe: the result, nothing else
  r = run({"script", "-qec", kBin + " scan --port " + slave.tty + " --units 1-3", "/dev/null"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("scan: unit 1 (1 of 3), 0 found"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("scan: unit 3 (3 of 3), 1 found: 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("unit 1 answers"), std::string::npos) << r.output;
  // --json: one document, also when no unit answers (then the failure's).
  r = rtukit({"scan", "--port", slave.tty, "--units", "7-8", "--json"});
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_EQ(r.output.find(R"({"time")"), r.output.rfind(R"({"time")")) << r.output;  // one document
  EXPECT_NE(r.output.find(R"("ok":false,"error":{"exit":3,"kind":"no_response")"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("no unit of 7-8 answered (timeout 100 ms"), std::string::npos) << r.output;
  r = rtukit({"scan", "--help"});
  EXPECT_NE(r.output.find("--timeout UINT=100 "), std::string::npos) << r.output;

  r = rtukit({"doctor", "--port", slave.tty, "--rounds", "3"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(r.output.starts_with("doctor: " + slave.tty + " unit 1, 3 probes, 3 answered\n")) << r.output;
  EXPECT_EQ(r.output.find("step 1 of 2"), std::string::npos) << r.output;
  r = run({"script", "-qec", kBin + " doctor --port " + slave.tty + " --rounds 3", "/dev/null"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("doctor: step 1 of 2, echo and turnaround: probe 3 of 3 (2 answered)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("doctor: step 2 of 2, error-free gap: 0 ms, request 1 of 3"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("recommended: "), std::string::npos) << r.output;
}

TEST(CliUsability, OneBasedAndReferenceAddresses) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  RunResult w = rtukit({"write", "--port", slave.tty, "40003", "77"});  // holding register 3 = address 2
  ASSERT_EQ(w.code, 0) << w.output;
  EXPECT_NE(w.output.find("note: 40003 is taken as a reference: holding register 3 (0-based 2"),
            std::string::npos)
      << w.output;
  EXPECT_NE(w.output.find("wrote 77 to holding register 40003 (0x0002) of unit 1\n"), std::string::npos)
      << w.output;
  // Addresses are printed as they were typed (1-based here), the address on the wire in hex beside them.
  RunResult r = rtukit({"read", "--port", slave.tty, "--one-based", "3"});
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.output, "3 (0x0002): 77\n");
  r = rtukit({"read", "--port", slave.tty, "2"});
  EXPECT_EQ(r.output, "2 (0x0002): 77\n");
  r = rtukit({"write", "--port", slave.tty, "30001", "5"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("names the input registers, which cannot be written"), std::string::npos)
      << r.output;
}

// --one-based prints 1-based addresses everywhere the command prints one:
// text, JSON, poll's table, CSV header and JSON lines, the failure's request;
// a reference prints as a reference (issue 28).
TEST(CliUsability, OneBasedAndReferenceAddressesPrintAsTyped) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  ASSERT_EQ(rtukit({"write", "--port", slave.tty, "2", "77", "78"}).code, 0);
  RunResult r = rtukit({"read", "--port", slave.tty, "--one-based", "3", "2"});
  EXPECT_EQ(r.output, "3 (0x0002): 77\n4 (0x0003): 78\n");
  r = rtukit({"read", "--port", slave.tty, "--one-based", "3", "2", "--json"});
  EXPECT_NE(r.output.find(R"("table":"holding","address":3,"pdu_address":2,"type":"u16","values":[77,78]})"),
            std::string::npos)
      << r.output;
  r = rtukit({"read", "--port", slave.tty, "--one-based", "3", "--type", "u32", "2", "--format", "hex"});
  EXPECT_EQ(r.output, "3 (0x0002): 0x004D004E\n5 (0x0004): 0x00000000\n");
  r = rtukit({"poll", "--port", slave.tty, "--one-based", "3", "2", "--count", "1", "-o", "csv"});
  EXPECT_TRUE(r.output.starts_with("time,3,4,error\n20")) << r.output;
  r = rtukit({"poll", "--port", slave.tty, "--one-based", "3", "2", "--count", "1"});
  EXPECT_NE(r.output.find("Z  [3]=77  [4]=78\n"), std::string::npos) << r.output;
  r = rtukit({"poll", "--port", slave.tty, "--one-based", "3", "--count", "1", "-o", "jsonl"});
  EXPECT_NE(r.output.find(R"("address":3,"pdu_address":2,"type")"), std::string::npos) << r.output;
  r = rtukit({"read", "--port", slave.tty, "--one-based", "200"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.output, "rtukit: FC03 read holding registers at 200 (0x00C7) x1 from unit 1 on " + slave.tty +
                          " 9600 8N1: Modbus exception 02 (illegal data address)\n");
  // The reference notation prints references, five or six digits as typed.
  r = rtukit({"read", "--port", slave.tty, "40003", "2"});
  EXPECT_EQ(r.output,
            "note: 40003 is taken as a reference: holding register 3 (0-based 2; for address 40003 write "
            "0x9C43)\n40003 (0x0002): 77\n40004 (0x0003): 78\n");
  r = rtukit({"read", "--port", slave.tty, "400003", "--json"});
  EXPECT_NE(r.output.find(R"("table":"holding","address":3,"pdu_address":2,"type":"u16","values":[77]})"),
            std::string::npos)
      << r.output;
  r = rtukit({"read", "--port", slave.tty, "400003"});
  EXPECT_EQ(r.output,
            "note: 400003 is taken as a reference: holding register 3 (0-based 2)\n400003 (0x0002): 77\n");
  r = rtukit({"write", "--port", slave.tty, "--coils", "00002", "1"});
  EXPECT_EQ(r.output,
            "note: 00002 is taken as a reference: coil 2 (0-based 1; for address 2 write 0x0002)\n"
            "wrote 1 to coil 00002 (0x0001) of unit 1\n");
  r = rtukit({"write", "--port", slave.tty, "00002", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("rtukit: address 00002 names a coil: add --coils to write coils\n"),
            std::string::npos)
      << r.output;
}

// A 400001 is not a plain address (past 65535), so the note offers no hex
// form; 10000 is no reference (discrete inputs are 10001..19999): refused,
// with the forms that mean what the user may have meant (issue 28).
TEST(CliUsability, ReferenceRefusalsNameTheRightForms) {
  RunResult r = rtukit({"read", "--port", "/dev/ttyUSB0", "10000"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(
      r.output,
      "rtukit: 10000 is not a reference: discrete inputs are 10001..19999 (six digits: 100001..165536); "
      "for address 10000 write 0x2710\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "40000"});
  EXPECT_EQ(
      r.output,
      "rtukit: 40000 is not a reference: holding registers are 40001..49999 (six digits: 400001..465536); "
      "for address 40000 write 0x9C40\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "400000"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.output,
            "rtukit: 400000 is not a reference: holding registers are 400001..465536 (five digits: "
            "40001..49999)\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "365537"});
  EXPECT_EQ(
      r.output,
      "rtukit: 365537 is not a reference: input registers are 300001..365536 (five digits: 30001..39999)\n");
  r = rtukit({"read", "--port", "/dev/ttyUSB0", "--one-based", "00000"});
  EXPECT_EQ(r.output,
            "rtukit: 00000 is not a reference: coils are 00001..09999 (six digits: 000001..065536)\n");
}

// readwrite (FC17) takes the reference notation and --one-based for both
// addresses, and prints the read addresses as typed (issue 28).
TEST(CliUsability, ReadWriteTakesReferencesForBothAddresses) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  RunResult r = rtukit({"readwrite", "--port", slave.tty, "40001", "2", "40002", "7", "8"});
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("40001 (0x0000): 0\n40002 (0x0001): 7\n"), std::string::npos) << r.output;
  EXPECT_EQ(rtukit({"read", "--port", slave.tty, "1", "2"}).output, "1 (0x0001): 7\n2 (0x0002): 8\n");
  r = rtukit({"readwrite", "--port", slave.tty, "--one-based", "2", "1", "3", "9", "--json"});
  EXPECT_NE(r.output.find(R"("written":{"address":3,"pdu_address":2,"count":1},"address":2,"pdu_address":1,)"
                          R"("values":[7]})"),
            std::string::npos)
      << r.output;
  r = rtukit({"readwrite", "--port", slave.tty, "0", "1", "30001", "9"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("rtukit: 30001 names the input registers: FC17 reads and writes holding registers"),
            std::string::npos)
      << r.output;
}

TEST(CliUsability, PollPrintsTimestampedLinesInEachFormat) {
  TempDir dir;
  Slave slave(dir);
  ASSERT_TRUE(slave.ready());
  ASSERT_EQ(rtukit({"write", "--port", slave.tty, "5", "11", "22"}).code, 0);
  RunResult t = rtukit({"poll", "--port", slave.tty, "5", "2", "--interval", "50", "--count", "2"});
  EXPECT_EQ(t.code, 0) << t.output;
  EXPECT_EQ(std::count(t.output.begin(), t.output.end(), '\n'), 3) << t.output;  // 2 lines + the summary
  EXPECT_NE(t.output.find("Z  [5]=11  [6]=22\n"), std::string::npos) << t.output;
  EXPECT_NE(t.output.find("poll: 2 polls, 0 failed"), std::string::npos);
  RunResult c =
      rtukit({"poll", "--port", slave.tty, "5", "2", "--interval", "50", "--count", "1", "-o", "csv"});
  EXPECT_TRUE(c.output.starts_with("time,5,6,error\n20")) << c.output;
  EXPECT_NE(c.output.find("Z,11,22,\n"), std::string::npos) << c.output;
  RunResult j =
      rtukit({"poll", "--port", slave.tty, "5", "2", "--interval", "50", "--count", "1", "-o", "jsonl"});
  EXPECT_NE(
      j.output.find(R"("ok":true,"unit":1,"table":"holding","address":5,"type":"u16","values":[11,22]})"),
      std::string::npos)
      << j.output;
  // Every poll failed: the error, as for read, and its exit code.
  RunResult f = rtukit({"poll", "--port", slave.tty, "500", "--interval", "50", "--count", "2"});
  EXPECT_EQ(f.code, 1) << f.output;
  EXPECT_NE(f.output.find("Z  error: illegal data address"), std::string::npos) << f.output;
}

// Every command's --help ends with examples, and its own options come
// before the link options.
TEST(CliUsability, EveryCommandHelpHasExamples) {
  const std::vector<std::vector<std::string>> commands = {{"read"},
                                                          {"poll"},
                                                          {"write"},
                                                          {"scan"},
                                                          {"slave"},
                                                          {"devices"},
                                                          {"map", "get"},
                                                          {"map", "set"},
                                                          {"map", "watch"},
                                                          {"map", "status"},
                                                          {"completion"},
                                                          {"map", "check"},
                                                          {"map", "registers"},
                                                          {"sim", "inverjet"},
                                                          {"sim", "rehand6600"},
                                                          {"sim", "map"},
                                                          {"gateway"},
                                                          {"bus"},
                                                          {"sniff"},
                                                          {"doctor"},
                                                          {"inverjet", "status"},
                                                          {"inverjet", "watch"},
                                                          {"inverjet", "start"},
                                                          {"inverjet", "pause"},
                                                          {"inverjet", "resume"},
                                                          {"inverjet", "stop"},
                                                          {"inverjet", "speed"},
                                                          {"inverjet", "plan", "show"},
                                                          {"inverjet", "plan", "set"},
                                                          {"inverjet", "plan", "clear"},
                                                          {"inverjet", "config"},
                                                          {"inverjet", "registers"},
                                                          {"inverjet", "get"},
                                                          {"inverjet", "set"},
                                                          {"rehand6600", "status"},
                                                          {"rehand6600", "watch"},
                                                          {"rehand6600", "hold"},
                                                          {"rehand6600", "pulse"},
                                                          {"rehand6600", "set"},
                                                          {"rehand6600", "errors"},
                                                          {"rehand6600", "registers"},
                                                          {"rehand6600", "get"},
#ifdef RTUKIT_EXAMPLE_DEVICE
                                                          {"thermostat", "get"},
                                                          {"thermostat", "set"},
                                                          {"thermostat", "watch"},
                                                          {"thermostat", "status"},
                                                          {"thermostat", "registers"},
                                                          {"sim", "thermostat"},
#endif
                                                          {"rehand6600", "registers"}};
  for (std::vector<std::string> c : commands) {
    c.push_back("--help");
    const RunResult r = rtukit(c);
    EXPECT_EQ(r.code, 0) << c[0];
    EXPECT_NE(r.output.find("\nExamples:\n  rtukit "), std::string::npos) << c[0] << " " << c[1] << r.output;
    const size_t link = r.output.find("[Option Group: Link options]");
    if (link != std::string::npos) {
      EXPECT_LT(r.output.find("-h,--help"), link);
      EXPECT_GT(r.output.find("--port"), link) << c[0];
    }
  }
}

// Issue 38: the man page was help2man's copy of the top-level help (no
// command's options, no exit codes, no examples) and listed the example
// thermostat. It is generated from the commands now: every command the
// completion knows has its section, the exit codes their table, a device's
// verbs their examples; groff reads it without a warning.
TEST(CliUsability, TheManPageHasEveryCommandItsExamplesAndTheExitCodes) {
  const RunResult page = rtukit({"manpage"});
  ASSERT_EQ(page.code, 0) << page.output;
  const RunResult completion = rtukit({"completion", "bash"});
  // Every path the completion offers ("rtukit sim map") is a section of the page.
  const std::string known_start = "local known=\"|";
  const size_t at = completion.output.find(known_start);
  ASSERT_NE(at, std::string::npos) << completion.output;
  const std::string known =
      completion.output.substr(at + known_start.size(), completion.output.find('"', at + known_start.size()) -
                                                            at - known_start.size());
  size_t commands = 0;
  for (size_t from = 0, bar; (bar = known.find('|', from)) != std::string::npos; from = bar + 1) {
    const std::string path = known.substr(from, bar - from);
    if (path == "rtukit") continue;
    ++commands;
    std::string roff_path;
    for (const char c : path) roff_path += c == '-' ? std::string("\\-") : std::string(1, c);
    EXPECT_NE(page.output.find(".SS \"" + roff_path + "\"\n"), std::string::npos) << path;
  }
  EXPECT_GT(commands, 40u);
  for (const char* says : {".SH EXIT STATUS\n.TP\n\\fB0\\fR\ndone\n",
                           "\\fB5\\fR\nrefused: another device answers", "rtukit inverjet start \\-\\-port",
                           "\\fB\\-\\-timeout UINT", ".SS \"rtukit rehand6600 hold\"", "docs/: inverjet.md"})
    EXPECT_NE(page.output.find(says), std::string::npos) << says;
#ifdef RTUKIT_EXAMPLE_DEVICE
  EXPECT_NE(page.output.find(".SS \"rtukit thermostat"), std::string::npos);
#else
  EXPECT_EQ(page.output.find("thermostat"), std::string::npos);  // a packaged build has no example device
#endif
  // groff with every warning on, its output thrown away: nothing on stderr.
  TempDir dir;
  const std::string file = dir / "rtukit.1";
  { std::ofstream(file) << page.output; }
  const RunResult groff = run({"sh", "-c", "groff -man -ww -z " + file + " 2>&1"});
  EXPECT_EQ(groff.code, 0) << groff.output;
  EXPECT_EQ(groff.output, "") << groff.output;
  // The top-level help lists the exit codes from the same table.
  const RunResult help = rtukit({"--help"});
  EXPECT_NE(help.output.find("Exit codes:\n  0  done\n  1  the device answered a Modbus exception"),
            std::string::npos)
      << help.output;
}

TEST(CliUsability, VersionAndCompletion) {
  RunResult v = rtukit({"--version"});
  EXPECT_EQ(v.code, 0);
  EXPECT_TRUE(v.output.starts_with("rtukit 0.1.0 (")) << v.output;
  RunResult c = rtukit({"completion", "bash"});
  EXPECT_EQ(c.code, 0);
  EXPECT_NE(c.output.find("\"rtukit sim map\")"), std::string::npos);
  EXPECT_NE(c.output.find("complete -F _rtukit rtukit"), std::string::npos);
  // The script completes what the binary has.
  RunResult b = run({"bash", "-c",
                     "eval \"$(" + kBin +
                         " completion bash)\"; COMP_WORDS=(rtukit sim ma); COMP_CWORD=2; "
                         "_rtukit; echo \"${COMPREPLY[@]}\""});
  EXPECT_NE(b.output.find("map"), std::string::npos) << b.output;
}

}  // namespace
