// `rtukit sniff`: listen to a line (a port, or a bus tap file), print each
// transaction in device terms with its timing, write a pcap for Wireshark,
// and sum up at the end. Listen-only: nothing is ever sent.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>

#include "commands.hpp"
#include "common.hpp"
#include "profiles.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/devices/profile/transaction_text.hpp"
#include "rtukit/devices/profile/typed_value.hpp"
#include "rtukit/devices/registry.hpp"
#include "rtukit/driver/sniffer.hpp"
#include "rtukit/io/listen_port.hpp"
#include "rtukit/io/now.hpp"
#include "rtukit/term/pcap_file.hpp"
#include "rtukit/term/tap_client.hpp"

namespace rtukit::cli {
namespace {

struct SniffArgs {
  LinkOptions link;
  std::string tap;
  std::string bus;                   ///< a running `rtukit bus --name NAME`
  std::vector<std::string> devices;  ///< inverjet@21
  std::vector<std::string> maps;     ///< FILE@U
  bool json = false;
  std::string pcap;
  bool overwrite = false;
  unsigned seconds = 0;
};

// Microseconds as milliseconds (and seconds) for printing.
double ms(uint64_t us) {
  return static_cast<double>(us) / 1000.0;
}
double seconds(uint64_t us) {
  return static_cast<double>(us) / 1e6;
}

using profile::UnitProfiles;

// --device NAME@UNIT and --map FILE@UNIT: the registry's devices and map files.
UnitProfiles unit_profiles(const SniffArgs& a) {
  UnitProfiles out;
  for (const std::string& d : a.devices) {
    const Outcome<devices::DeviceAt> at = devices::find_at(d);
    if (!at) throw Failure{kUsage, fmt::format("--device: {}", at.error().reason())};
    out[at->unit.value] = at->entry->profile;
  }
  for (const std::string& m : a.maps) {
    const auto split = profile::split_at_unit(m);
    if (!split) throw Failure{kUsage, fmt::format("--map: {}", split.error().reason())};
    const profile::Profile& p = load_map_or_fail(split->first);
    out[device_unit(split->second, p).value] = &p;
  }
  return out;
}

// The --pcap file, if asked for.
std::unique_ptr<term::PcapFile> open_pcap(const SniffArgs& a) {
  if (a.pcap.empty()) return nullptr;
  Outcome<std::unique_ptr<term::PcapFile>> f = term::PcapFile::create(a.pcap, a.overwrite);
  if (!f.ok()) throw Failure{exit_code(f.error().error()), fmt::format("--pcap {}", f.error().reason())};
  return std::move(*f);
}

// Times are printed from `origin` (when sniffing started; 0 for a tap, whose times start with the bus).
void report(const SniffArgs& a, Sniffer& s, const UnitProfiles& profiles, term::PcapFile* pcap,
            uint64_t origin = 0) {
  for (const SniffedTransaction& t : s.take()) {
    const SniffedFrame& first = t.request ? *t.request : *t.response;
    if (pcap) {
      if (t.request) pcap->frame(t.request->bytes, t.request->start_us, true);
      if (t.response) pcap->frame(t.response->bytes, t.response->start_us, !t.request);
    }
    const std::string text = profile::transaction_text(t, profiles);
    const std::vector<std::string> flags = s.forensics(t);
    if (a.json) {
      Json j = json_document();
      j["t_us"] = first.start_us - std::min(origin, first.start_us);
      if (t.request) {
        j["unit"] = t.request->unit();
        j["function"] = t.request->function();
        j["request"] = hex(t.request->bytes);
      }
      if (t.response) j["response"] = hex(t.response->bytes);
      if (t.turnaround_us) j["turnaround_us"] = *t.turnaround_us;
      j["text"] = text;
      j["flags"] = flags;
      print_json(j);
    } else {
      std::string line =
          fmt::format("{:10.3f} {}", seconds(first.start_us - std::min(origin, first.start_us)), text);
      if (t.turnaround_us) line += fmt::format("  [turnaround {:.2f} ms]", ms(*t.turnaround_us));
      for (const std::string& f : flags) line += "  [" + f + "]";
      fmt::print("{}\n", line);
    }
  }
  std::fflush(stdout);
}

void print_summary(const Sniffer& s, bool json) {
  const SnifferSummary& m = s.summary();
  if (json) {
    Json j = json_document();
    j["summary"] = {{"transactions", m.transactions},
                    {"answered", m.answered},
                    {"exceptions", m.exceptions},
                    {"no_response", m.no_response},
                    {"crc_errors", m.crc_errors},
                    {"glued", m.glued},
                    {"split", m.split},
                    {"t15_violations", m.t15_violations},
                    {"short_gaps", m.short_gaps},
                    {"turnaround_p50_us", m.turnaround_percentile(50)},
                    {"turnaround_p99_us", m.turnaround_percentile(99)},
                    {"utilisation", m.utilisation()}};
    print_json(j);
    return;
  }
  fmt::print(
      stderr,
      "sniff: {} transactions, {} answered, {} exceptions, {} without response, {} CRC errors, {} glued, {} "
      "split, {} t1.5 gaps, {} short silences; turnaround p50 {:.2f} ms, p99 {:.2f} ms; line busy {:.1f} %\n",
      m.transactions, m.answered, m.exceptions, m.no_response, m.crc_errors, m.glued, m.split,
      m.t15_violations, m.short_gaps, ms(m.turnaround_percentile(50)), ms(m.turnaround_percentile(99)),
      100.0 * m.utilisation());
}

// One character of a bus tap: exact times from the bus itself.
void feed_tap(Sniffer& s, const term::TapCharacter& c) {
  s.flush(c.end_us);
  if (!c.dropped) s.feed(c.heard, c.end_us);
}

// `--bus NAME`: the live tap of a running `rtukit bus --name NAME`, with the
// bus's own rate and its exact character times.
int sniff_bus(const SniffArgs& a, const UnitProfiles& profiles) {
  const std::string path = bus_tap_socket(a.bus);
  Outcome<std::unique_ptr<term::TapClient>> client = term::TapClient::connect(path);
  if (!client.ok() && client.error().code() == Errc::not_connected)
    throw Failure{kIoError, fmt::format("--bus {}: no bus of that name is running ({}); start one with "
                                        "`rtukit bus --name {}`",
                                        a.bus, client.error().reason(), a.bus)};
  if (!client.ok()) throw Failure{kIoError, fmt::format("--bus {}: cannot use {}", a.bus, path)};
  const Interruptible interrupt;
  std::unique_ptr<Sniffer> s;
  std::unique_ptr<term::PcapFile> pcap = open_pcap(a);
  int64_t offset = 0;  // our clock minus the bus's
  const uint64_t until = a.seconds ? io::now_us() + uint64_t{a.seconds} * 1'000'000 : 0;
  bool ended = false;
  while (!interrupt.interrupted() && !ended && (!until || io::now_us() < until)) {
    Outcome<std::vector<std::string>> read = (*client)->read_lines(std::chrono::milliseconds(5));
    ended = !read.ok();  // the bus stopped: what it sent is reported below, then the summary
    const std::vector<std::string> lines = ended ? std::vector<std::string>{} : std::move(*read);
    for (const std::string& line : lines) {
      if (!s) {
        // The first line is the header: the bus's rate and clock.
        const std::optional<term::TapHeader> h = term::parse_tap_header(line);
        if (!h) throw Failure{kIoError, fmt::format("--bus {}: not a bus tap", a.bus)};
        offset = static_cast<int64_t>(io::now_us()) - static_cast<int64_t>(h->now_us);
        s = std::make_unique<Sniffer>(SnifferConfig{.baud = h->baud,
                                                    .bits_per_char = h->bits_per_char,
                                                    .response_timeout_us = a.link.timeout_ms * 1000u});
        fmt::print(stderr,
                   "sniff: bus {} ({} baud, t1.5 {:.2f} ms, t3.5 {:.2f} ms), Ctrl-C for the summary\n", a.bus,
                   h->baud, ms(s->t15_us()), ms(s->t35_us()));
        continue;
      }
      if (const std::optional<term::TapCharacter> c = term::parse_tap_line(line)) feed_tap(*s, *c);
    }
    if (s) {
      // Close frames only as far as the tap has surely arrived: a busy bus
      // process (or one under emulation) publishes a character some time
      // after the line time it carries, and closing a frame at the bus's
      // present would cut it into garbage before its last characters come.
      constexpr int64_t kTapLagUs = 200'000;
      s->flush(static_cast<uint64_t>(
          std::max<int64_t>(0, static_cast<int64_t>(io::now_us()) - offset - kTapLagUs)));
      report(a, *s, profiles, pcap.get());
    }
  }
  client->reset();
  if (!s) throw Failure{kIoError, fmt::format("--bus {}: the bus closed before its tap began", a.bus)};
  if (ended) fmt::print(stderr, "sniff: the bus {} has stopped\n", a.bus);
  s->flush(io::now_us() - static_cast<uint64_t>(offset) + 10'000'000);
  report(a, *s, profiles, pcap.get());
  print_summary(*s, a.json);
  return kOk;
}

int run_sniff(const SniffArgs& a) {
  if ((a.tap.empty() ? 0 : 1) + (a.link.port.empty() ? 0 : 1) + (a.bus.empty() ? 0 : 1) != 1)
    throw Failure{kUsage, "sniff takes one of --port P, --bus NAME or --tap FILE"};
  const UnitProfiles profiles = unit_profiles(a);
  if (!a.bus.empty()) return sniff_bus(a, profiles);
  const uint32_t bits =
      1 + a.link.data_bits + (parity_letter(a.link.parity) == 'N' ? 0 : 1) + a.link.stop_bits;
  Sniffer s(SnifferConfig{.baud = a.link.baud,
                          .bits_per_char = bits,
                          .response_timeout_us = static_cast<uint32_t>(a.link.timeout_ms) * 1000});
  std::unique_ptr<term::PcapFile> pcap = open_pcap(a);
  if (!a.tap.empty()) {
    std::ifstream in(a.tap);
    if (!in) throw Failure{kIoError, fmt::format("--tap {}: cannot read", a.tap)};
    std::string line;
    uint64_t last = 0;
    while (std::getline(in, line)) {
      const std::optional<term::TapCharacter> c = term::parse_tap_line(line);
      if (!c) continue;
      last = c->end_us;
      feed_tap(s, *c);
      report(a, s, profiles, pcap.get());
    }
    s.flush(last + 10'000'000);
    report(a, s, profiles, pcap.get());
    print_summary(s, a.json);
    return kOk;
  }
  // A port, listen-only: opened, configured, never written.
  const io::PortSpec spec = a.link.spec(false);
  if (spec.kind != io::PortSpec::Kind::serial)
    throw Failure{kUsage, "sniff listens on a serial port or a bus port (/dev/ttyUSB0, /tmp/bus2)"};
  Result<std::unique_ptr<io::ListenPort>> port = io::ListenPort::open(spec.path, spec.serial);
  if (!port.ok()) fail(port.error(), "sniff " + spec.path);
  const Interruptible interrupt;
  fmt::print(stderr,
             "sniff: listening on {} ({} baud, t1.5 {:.2f} ms, t3.5 {:.2f} ms), Ctrl-C for the summary\n",
             spec.path, a.link.baud, ms(s.t15_us()), ms(s.t35_us()));
  const uint64_t char_us = uint64_t{bits} * 1'000'000 / a.link.baud;
  const uint64_t until = a.seconds ? io::now_us() + uint64_t{a.seconds} * 1'000'000 : 0;
  const uint64_t origin = io::now_us();
  while (!interrupt.interrupted() && (!until || io::now_us() < until)) {
    // A failed read (an unplugged adapter) is heard as silence until Ctrl-C or --seconds.
    const Result<io::ListenPort::Chunk> chunk = (*port)->read(std::chrono::milliseconds(5));
    const uint64_t now = chunk.ok() ? chunk->at_us : io::now_us();
    if (chunk.ok()) {
      // A chunk arrives at once; its bytes ended one character apart.
      const size_t n = chunk->bytes.size();
      for (size_t i = 0; i < n; ++i)
        s.feed(chunk->bytes[i], now - static_cast<uint64_t>(n - 1 - i) * char_us);
    }
    s.flush(now);
    report(a, s, profiles, pcap.get(), origin);
  }
  port->reset();
  s.flush(io::now_us() + 10'000'000);
  report(a, s, profiles, pcap.get(), origin);
  print_summary(s, a.json);
  return kOk;
}

}  // namespace

void add_sniff_command(CLI::App& app, Action& action) {
  add_command<SniffArgs>(
      app, action, "sniff", "listen to a line: transactions in device terms, timing, pcap (sends nothing)",
      [](CLI::App& cmd, SniffArgs& a) {
        cmd.add_option("--bus", a.bus, "listen to a running `rtukit bus --name NAME` (its exact timing)");
        cmd.add_option("--tap", a.tap, "read a bus tap file (rtukit bus --tap) instead of a port");
        cmd.add_option("--device", a.devices,
                       "decode a unit as a registered device (rtukit devices): inverjet@21 (repeatable)");
        cmd.add_option("--map", a.maps, "decode a unit with a register-map file: meter.yaml@3 (repeatable)");
        cmd.add_flag("--json", a.json, "one JSON document per transaction (docs/json.md)");
        cmd.add_option("--pcap", a.pcap,
                       "also write the frames to a pcap file (tshark -d udp.port==502,mbrtu)");
        cmd.add_flag("--overwrite", a.overwrite, "replace a --pcap file that is not a capture");
        cmd.add_option("--seconds", a.seconds, "stop after this many seconds (0: at Ctrl-C)");
        a.link.add_to(cmd, false);
        // Listen-only: the port is optional (a tap file works too).
        cmd.get_option_group("Link options")->get_option("--port")->required(false);
        examples(cmd, {"rtukit sniff --port /tmp/bus2 --baud 9600 --device inverjet@21 --device rehand6600@1",
                       "rtukit sniff --port /dev/ttyUSB0 --baud 19200 --parity even --pcap line.pcap",
                       "rtukit sniff --bus lab --device inverjet@21",
                       "rtukit sniff --tap bus.tap --baud 9600 --json"});
      },
      [](const SniffArgs& a) { return run_sniff(a); });
}

}  // namespace rtukit::cli
