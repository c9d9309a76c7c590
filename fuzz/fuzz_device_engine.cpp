// The slave engine serving each device profile as its simulator does (the
// Inverjet and the Rehand 6600 from make_sim_device, and a register-map
// device from examples/maps/energy-meter.yaml), on arbitrary request PDUs
// and time steps.
// Properties: never crashes; a request answered with an exception changed
// nothing in the device's image (all-or-nothing writes: compared word for
// word, live values brought up to date first); an exception is fc|0x80 with a
// code 01..04; any other answer is the request's function and decodes as the
// response to that request (decode_response: lengths, echoes, byte counts);
// a malformed request and a broadcast are never answered.
//
// Input: the device (1 byte), then items: 0 or 255 and a byte = time passes
// (x 50 ms); 254, n, n bytes = a broadcast PDU; 1..253 = that many bytes of PDU.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "fuzz_devices.hpp"
#include "rtukit/core.hpp"

namespace {

using namespace rtukit;

// Brings every space's live values into the image (a model refreshes them
// before a read): a read of the first readable register of each space.
void refresh_all(profile::Model& m) {
  bool done[4] = {};
  for (const profile::Row& r : m.map().rows()) {
    const auto space = static_cast<size_t>(r.space);
    if (done[space]) continue;
    std::array<uint16_t, 1> one{};
    done[space] = m.read(r.space, r.address, one) == Errc::ok;
  }
}

void leave_listen_only(SlaveEngine& engine, UnitId unit) {
  // Listen-only mode would silence every later request (its own behaviour is
  // tested in tests/core_slave_test.cpp).
  if (!engine.listen_only()) return;
  const uint8_t restart[] = {0x08, 0x00, 0x01, 0x00, 0x00};
  std::array<uint8_t, kMaxPduSize> scratch{};
  (void)engine.handle_pdu(unit, restart, scratch);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  std::unique_ptr<profile::Model> model = fuzz::make_device(data[0]);
  SlaveEngine engine;
  UnitId unit{fuzz::device_unit(*model)};
  if (engine.add_unit(unit, *model)) std::abort();
  uint64_t now = 0;
  std::array<uint8_t, kMaxPduSize> out{};

  size_t at = 1;
  while (at < size) {
    const uint8_t item = data[at++];
    if (item == 0 || item == 255) {
      if (at < size) now += uint64_t{data[at++]} * 50;
      model->advance_to(now);
      continue;
    }
    const bool broadcast = item == 254;
    size_t n = item;
    if (broadcast) {
      if (at >= size) break;
      n = data[at++] % (kMaxPduSize + 1);
    }
    if (n == 0 || n > size - at) break;
    const std::span<const uint8_t> pdu(data + at, n);
    at += n;

    refresh_all(*model);
    const std::vector<uint16_t> before(model->image().words().begin(), model->image().words().end());
    const SlaveEngine::Handled h = engine.handle_pdu(broadcast ? kBroadcast : unit, pdu, out);
    const Result<Request> request = decode_request(pdu, model->quirks());
    if (broadcast && h.length) std::abort();  // nobody answers a broadcast
    if (h.length) {
      const std::span<const uint8_t> answer(out.data(), h.length);
      if (answer[0] == (pdu[0] | kExceptionBit)) {
        if (answer.size() != 2 || answer[1] < 1 || answer[1] > 4) std::abort();
        const auto words = model->image().words();
        if (!std::equal(words.begin(), words.end(), before.begin(), before.end())) std::abort();
      } else {
        if (!request.ok() || answer[0] != pdu[0]) std::abort();
        if (!decode_response(*request, answer).ok()) std::abort();
      }
    } else if (!broadcast && !engine.listen_only() && !request.ok() && request.error().is_exception()) {
      std::abort();  // a request the codec answers with an exception went unanswered
    }
    if (h.bank) h.bank->after_response();
    // As the simulator host: a new address takes effect after the answer.
    if (const profile::LinkChange change = model->take_link_change(); change.address) {
      if (!engine.change_unit_address(unit, UnitId{*change.address})) unit = UnitId{*change.address};
    }
    leave_listen_only(engine, unit);
  }
  return 0;
}
