// The Inverjet command path the MQTT bridge (.../set/<name> messages) and the
// pool panel (WebSocket {"op": name, ...}) share: mqtt_command_body (the
// stale guard and the body) and inverjet::run_command, run through a typed Client
// whose link is an in-process simulated machine (a MemoryLink answered by a
// slave engine serving the simulator's model, on virtual time).
// Properties: never crashes and never throws (an exception would end the
// bridge's or the panel's bus thread); a message mqtt_command_body lets
// through is one JSON object with a numeric "ts" no more than max_age old
// and kMaxCommandAheadS ahead (nothing else ever acts); a refused message
// (retained, not that object, stale) reaches nothing; a
// command refused by the checks (invalid_argument, refused) sent no write to
// the machine; no command sends more than one write (never applied halfway);
// every reason is valid UTF-8, so the result document the bridge and the
// panel publish ({"ok": false, "error": reason}) serialises. Each payload is
// also the panel's check of what a page typed (inverjet::check_typed): an
// answer with a "why", no exception, always serialisable.
//
// Input: lines "NAME PAYLOAD" (payload up to the end of the line; a line
// starting with '!' is a retained message), at most 8, run in order on one
// machine with 4 s of machine time between them.
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>

#include "fuzz_support.hpp"
#include "rtukit/base/clock.hpp"
#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/inverjet/sim.hpp"
#include "rtukit/devices/inverjet/typed.hpp"
#include "rtukit/driver/master.hpp"
#include "rtukit/driver/memory_link.hpp"
#include "rtukit/programs/inverjet_bridge.hpp"

namespace {

using namespace rtukit;
using namespace std::chrono_literals;

constexpr double kNow = 1.8e9;  // "now" for the stale guard, seconds since the epoch
constexpr unsigned kMaxAge = programs::kMaxCommandAgeS;

bool is_write(uint8_t function) {
  switch (static_cast<Function>(function)) {
    case Function::write_single_coil:
    case Function::write_single_register:
    case Function::write_multiple_coils:
    case Function::write_multiple_registers:
    case Function::mask_write_register:
    case Function::read_write_multiple_registers:
      return true;
    default:
      return false;
  }
}

// The machine behind a MemoryLink, counting the writes that reach it.
struct Rig {
  Rig() {
    (void)engine.add_unit(UnitId{inverjet::kDefaultAddress}, *model);
    auto link = std::make_unique<MemoryLink>(clock, [this](std::span<const uint8_t> request) {
      if (request.size() > 1 && is_write(request[1])) ++writes;
      std::array<uint8_t, kMaxRtuAduSize> out{};
      const size_t n = engine.handle_rtu(request, out).length;
      return MemoryLink::Reply{{out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}, 2ms};
    });
    master =
        std::make_unique<Master>(std::move(link), MasterOptions{.response_timeout = 100ms, .clock = &clock});
    client = std::make_unique<inverjet::Client>(*master);
  }
  ManualClock clock;
  std::unique_ptr<profile::Model> model = inverjet::make_sim_device().model;
  SlaveEngine engine;
  unsigned writes = 0;
  std::unique_ptr<Master> master;
  std::unique_ptr<inverjet::Client> client;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view input(reinterpret_cast<const char*>(data), size);
  Rig rig;
  uint64_t machine_ms = 0;
  for (int line = 0; line < 8 && !input.empty(); ++line) {
    const size_t nl = input.find('\n');
    std::string_view text = input.substr(0, nl);
    input = nl == std::string_view::npos ? std::string_view() : input.substr(nl + 1);
    const bool retained = !text.empty() && text[0] == '!';
    if (retained) text.remove_prefix(1);
    const size_t space = text.find(' ');
    const std::string_view name = text.substr(0, space);
    const std::string_view payload =
        space == std::string_view::npos ? std::string_view() : text.substr(space + 1);

    machine_ms += 4000;
    rig.model->advance_to(machine_ms);
    const unsigned writes_before = rig.writes;
    const uint64_t requests_before = rig.master->stats().requests;
    nlohmann::json body, result;
    rtukit::Status e = programs::mqtt_command_body(name, payload, retained, kNow, kMaxAge, body);
    const bool stale = static_cast<bool>(e);
    if (stale) {
      if (e.code() != Errc::refused) std::abort();
    } else {
      // Only the documented form gets through: never a retained message.
      if (retained || !body.is_object() || !body.contains("ts") || !body["ts"].is_number()) std::abort();
      double ts = body["ts"].get<double>();
      if (ts > 1e12) ts /= 1000;
      if (!(kNow - ts <= kMaxAge) || ts - kNow > programs::kMaxCommandAheadS) std::abort();
      e = inverjet::run_command(*rig.client, name, body, result);
    }
    const unsigned writes = rig.writes - writes_before;
    if (writes > 1) std::abort();
    if (e && !e.is_exception() && (e.code() == Errc::invalid_argument || e.code() == Errc::refused) && writes)
      std::abort();
    if (stale && rig.master->stats().requests != requests_before) std::abort();  // nothing reached the bus
    if (e) {
      if (!fuzz::valid_utf8(e.reason())) std::abort();
      result["error"] = std::string(e.reason());
    }
    result["ok"] = !e;
    (void)result.dump();  // what the bridge and the panel publish

    // The pool panel's check of what a page typed ({"op": "check"}:
    // inverjet/typed.hpp), on the same payload: an answer with a "why" for
    // any JSON, never an exception, and it serialises (an excerpt of what
    // was typed is never half a character).
    const nlohmann::json typed = nlohmann::json::parse(payload, nullptr, false);
    if (!typed.is_discarded()) {
      const nlohmann::json answer = inverjet::check_typed(typed);
      if (!answer.is_object() || !answer.contains("why") || !answer["why"].is_string()) std::abort();
      (void)answer.dump();
    }
  }
  return 0;
}
