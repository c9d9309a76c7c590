// wire_bench: how close a master gets to the physical limit of a serial line.
//
// On the virtual bus (`rtukit bus`, paced at its baud rate), a simulator
// answers and a master polls as fast as it can for a while: ours, a
// libmodbus master and a pymodbus master, one after the other in the same
// run, on the same bus. The physical limit of one transaction is the
// request's and the answer's characters plus the two t3.5 silences the
// Modbus serial line rule requires (before the answer, before the next
// request); the figure is transactions/s as a fraction of 1 / that time.
//
//   build/default/bench/wire_bench [--seconds S] [--markdown]
#include <modbus/modbus.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "../tests/process.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/io/port.hpp"

using namespace rtukit;
using namespace rtukit::test;
using namespace std::chrono_literals;

namespace {

struct Workload {
  const char* name;
  const char* device;  // rtukit sim DEVICE
  uint8_t unit;
  uint16_t address, count;
};

struct Row {
  std::string workload;
  uint32_t baud;
  double limit, ours, libmodbus, pymodbus;
};

using Clock = std::chrono::steady_clock;

double run_ours(const std::string& port, uint32_t baud, const Workload& w, double seconds) {
  io::PortSpec spec = *io::parse_port(port, false);
  spec.serial.baud = baud;
  Master m(io::make_link(spec), MasterOptions{.response_timeout = 1000ms});
  std::vector<uint16_t> regs(w.count);
  unsigned ok = 0;
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  const auto t0 = Clock::now();
  while (Clock::now() < until)
    if (m.read_holding_registers(UnitId{w.unit}, w.address, regs).ok()) ++ok;
  return ok / std::chrono::duration<double>(Clock::now() - t0).count();
}

double run_libmodbus(const std::string& port, uint32_t baud, const Workload& w, double seconds) {
  modbus_t* ctx = modbus_new_rtu(port.c_str(), static_cast<int>(baud), 'N', 8, 1);
  if (!ctx) return 0;
  modbus_set_slave(ctx, w.unit);
  modbus_set_response_timeout(ctx, 1, 0);
  if (modbus_connect(ctx) != 0) {
    modbus_free(ctx);
    return 0;
  }
  std::vector<uint16_t> regs(w.count);
  unsigned ok = 0;
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  const auto t0 = Clock::now();
  while (Clock::now() < until)
    if (modbus_read_registers(ctx, w.address, w.count, regs.data()) == w.count) ++ok;
  const double rate = ok / std::chrono::duration<double>(Clock::now() - t0).count();
  modbus_close(ctx);
  modbus_free(ctx);
  return rate;
}

double run_pymodbus(const std::string& port, uint32_t baud, const Workload& w, double seconds) {
  const std::string script =
      "import time\n"
      "from pymodbus.client import ModbusSerialClient\n"
      "c = ModbusSerialClient(port='" +
      port + "', baudrate=" + std::to_string(baud) +
      ", timeout=1)\n"
      "c.connect()\n"
      "ok = 0\n"
      "t0 = time.monotonic()\n"
      "while time.monotonic() - t0 < " +
      std::to_string(seconds) +
      ":\n"
      "    r = c.read_holding_registers(" +
      std::to_string(w.address) + ", " + std::to_string(w.count) + ", slave=" + std::to_string(w.unit) +
      ")\n"
      "    if not r.isError(): ok += 1\n"
      "print('rate', ok / (time.monotonic() - t0))\n";
  const RunResult r = run({"/usr/bin/python3", "-c", script},
                          std::chrono::milliseconds(static_cast<long>(seconds * 1000) + 20000));
  const size_t at = r.output.find("rate ");
  return at == std::string::npos ? 0 : std::stod(r.output.substr(at + 5));
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5;
  bool markdown = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--seconds") && i + 1 < argc) seconds = std::stod(argv[++i]);
    if (!std::strcmp(argv[i], "--markdown")) markdown = true;
  }
  const std::string rtukit = RTUKIT_BIN;
  const Workload workloads[] = {{"Inverjet state registers (FC03 0x0021 x4)", "inverjet", 21, 0x21, 4},
                                {"Rehand 6600 table 1 (FC03 0x0000 x48)", "rehand6600", 1, 0, 48}};
  std::vector<Row> rows;
  // The Inverjet runs at 1200..19200 baud; the Rehand 6600's own rate is 115200.
  const std::pair<const Workload*, uint32_t> runs[] = {
      {&workloads[0], 9600}, {&workloads[1], 9600}, {&workloads[0], 19200}, {&workloads[1], 115200}};
  for (const auto& [wp, baud] : runs) {
    const Workload& w = *wp;
    {
      TempDir dir;
      Process bus({rtukit, "bus", "--ports", "2", "--links", (dir / "dev") + "," + (dir / "host"), "--baud",
                   std::to_string(baud)});
      if (!bus.wait_for_output("listening on")) return 1;
      Process sim({rtukit, "sim", w.device, "--listen", dir / "dev", "--baud", std::to_string(baud),
                   "--no-state", "--no-console"});
      if (!sim.wait_for_output("listening on")) return 1;
      const double char_us = 10e6 / baud;
      const double t35 = RtuTiming::for_serial(baud, 10).t35_us;
      const double chars = 8 + 5 + 2.0 * w.count;
      const double limit = 1e6 / (chars * char_us + 2 * t35);
      Row r{w.name, baud, limit, 0, 0, 0};
      r.ours = run_ours(dir / "host", baud, w, seconds);
      r.libmodbus = run_libmodbus(dir / "host", baud, w, seconds);
      r.pymodbus = run_pymodbus(dir / "host", baud, w, seconds);
      rows.push_back(r);
      std::fprintf(stderr, "%s at %u: limit %.1f/s, ours %.1f, libmodbus %.1f, pymodbus %.1f\n", w.name, baud,
                   limit, r.ours, r.libmodbus, r.pymodbus);
    }
  }
  std::printf(
      markdown
          ? "| workload | baud | limit tx/s | rtukit | libmodbus | pymodbus |\n|---|---|---|---|---|---|\n"
          : "%-44s %7s %10s %16s %16s %16s\n",
      "workload", "baud", "limit tx/s", "rtukit", "libmodbus", "pymodbus");
  for (const Row& r : rows) {
    if (markdown)
      std::printf("| %s | %u | %.1f | %.1f (%.1f %%) | %.1f (%.1f %%) | %.1f (%.1f %%) |\n",
                  r.workload.c_str(), r.baud, r.limit, r.ours, 100 * r.ours / r.limit, r.libmodbus,
                  100 * r.libmodbus / r.limit, r.pymodbus, 100 * r.pymodbus / r.limit);
    else
      std::printf("%-44s %7u %10.1f %9.1f %5.1f%% %9.1f %5.1f%% %9.1f %5.1f%%\n", r.workload.c_str(), r.baud,
                  r.limit, r.ours, 100 * r.ours / r.limit, r.libmodbus, 100 * r.libmodbus / r.limit,
                  r.pymodbus, 100 * r.pymodbus / r.limit);
  }
  return 0;
}
