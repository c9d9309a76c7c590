// The Rehand 6600 remote-control rules (rehand6600/session.hpp) on arbitrary
// sequences of clients joining and leaving, presses, renewals, releases,
// Stop, one-shot commands, time steps, polls with any table-1 values and
// errors, and failed writes. Properties, checked after every step:
//  - no hold-type command is wanted without a live press behind it: a press
//    of a joined client, on that command with that value, whose lease has
//    not run out (0x006A is also wanted while a loss of control is stopped);
//  - an ended press never moves again: a renewal of it is refused and
//    changes nothing wanted;
//  - a phone drive press that lapses or whose phone leaves turns the
//    emergency stop on at once (D-12);
//  - nothing is wanted while the error overlay is active (D-8);
//  - at most one phone drives.
//
// Input: a stream of 5-byte steps: op, client, a, b, c.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <utility>

#include "rtukit/devices/rehand6600/session.hpp"

namespace {

using namespace rtukit::rehand6600;
using namespace std::chrono_literals;

constexpr uint16_t kHolds[] = {reg::kStandSit,  reg::kSeatLift,     reg::kBackrest,     reg::kSeatTilt,
                               reg::kLegRotate, reg::kLegExtend,    reg::kPlateTilt,    reg::kAntiPinch,
                               reg::kHostReady, reg::kSos,          reg::kPhoneForward, reg::kPhoneReverse,
                               reg::kPhoneLeft, reg::kPhoneRight,   reg::kPhoneHorn,    reg::kLight,
                               reg::kDriveMode, reg::kSpeedLevel,   reg::kPhoneLight,   reg::kPhoneLeftSignal};

void require(bool ok) {
  if (!ok) std::abort();
}

bool is_phone_drive(uint16_t a) {
  return a >= reg::kPhoneForward && a <= reg::kPhoneRight;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Session session;
  Session::TimePoint now{std::chrono::hours(1)};
  Snapshot status;
  status.valid = true;
  status.regs[reg::kDeviceId] = kDeviceId;
  status.regs[reg::kMotion] = 1;
  status.regs[reg::kClutch] = 1;
  uint16_t error = 0;
  session.on_status(status, error, now);
  std::array<bool, 4> joined{};
  std::array<ClientKind, 4> kinds{ClientKind::display, ClientKind::phone, ClientKind::phone, ClientKind::tool};
  std::set<std::pair<uint64_t, uint64_t>> ended;  // (client, press)
  std::array<uint64_t, 4> next_press{1, 1, 1, 1};
  // Client ids are never reused (the daemon numbers its connections): a
  // slot that joins again is a new client.
  std::array<uint64_t, 4> id{1, 2, 3, 4};
  const auto slot_of = [&](uint64_t client) { return static_cast<size_t>((client - 1) % 4); };

  for (size_t at = 0; at + 5 <= size; at += 5) {
    const uint8_t op = data[at] % 12;
    const uint8_t slot = data[at + 1] % 4;
    const uint64_t client = id[slot];
    const uint8_t a = data[at + 2], b = data[at + 3], c = data[at + 4];
    const uint16_t command = kHolds[a % std::size(kHolds)];
    switch (op) {
      case 0:
        session.join(client, kinds[slot]);
        joined[slot] = true;
        break;
      case 1:
        session.leave(client, now);
        if (joined[slot]) {
          joined[slot] = false;
          id[slot] += 4;
          next_press[slot] = 1;
        }
        break;
      case 2: {  // a press, usually with a new id, sometimes an old or a wild one
        const uint64_t press = c < 200 ? next_press[slot]++ : c;
        (void)session.press(client, command, b % 4, press, now);
        break;
      }
      case 3:
        (void)session.renew(client, c % 16, now);
        break;
      case 4:
        session.release(client, c % 16, now);
        break;
      case 5:
        if (b & 1)
          session.stop_all(now);
        else
          session.lift_stop();
        break;
      case 6:
        (void)session.check_command(client, command, b % 6);
        break;
      case 7:  // time passes
        now += std::chrono::milliseconds(a * 4 + 1);
        session.tick(now);
        break;
      case 8:  // a poll: any value in any register
        status.regs[a % reg::kStatusCount] = static_cast<uint16_t>(b | (c << 8));
        status.regs[reg::kErrorCode] = 0;
        ++status.sequence;  // a new reading (the rules wait for one after a link loss)
        session.on_status(status, error, now, /*stop_settled=*/(c & 1) != 0);
        break;
      case 9:  // the error overlay comes and goes
        error = b % 3 == 0 ? 0 : b % 3 == 1 ? uint16_t{0x10C3} : kMasterCommunicationError;
        session.on_status(status, error, now);
        break;
      case 10:
        session.on_write_failed(command, now);
        break;
      case 11: {  // a renewal of a press that ended: refused, changes nothing
        if (ended.empty()) break;
        auto it = ended.begin();
        std::advance(it, static_cast<long>(a % ended.size()));
        std::array<uint16_t, reg::kCommandCount> before{};
        for (uint16_t i = 0; i < reg::kCommandCount; ++i)
          before[i] = session.wanted(static_cast<uint16_t>(reg::kCommandFirst + i));
        require(static_cast<bool>(session.renew(it->first, it->second, now)));
        for (uint16_t i = 0; i < reg::kCommandCount; ++i)
          require(before[i] >= session.wanted(static_cast<uint16_t>(reg::kCommandFirst + i)) ||
                  before[i] == 0);
        break;
      }
    }
    bool emergency_now = false;
    for (const auto& e : session.take_events()) {
      if (e.type == Session::Event::Type::press_ended) {
        ended.insert({e.client, e.press});
        if (e.emergency) emergency_now = true;
        // A phone's drive press ended by a lapse or by leaving: the stop command.
        if (kinds[slot_of(e.client)] == ClientKind::phone && is_phone_drive(e.command) &&
            (e.reason == "no renewal within the lease" || e.reason == "the phone's connection was lost"))
          require(e.emergency);
      }
    }
    if (emergency_now) require(session.emergency() && session.wanted(reg::kAntiPinch) == 1);
    // No motion without a live press.
    for (uint16_t i = 0; i < reg::kCommandCount; ++i) {
      const auto address = static_cast<uint16_t>(reg::kCommandFirst + i);
      const uint16_t want = session.wanted(address);
      if (want == 0) continue;
      if (address == reg::kAntiPinch && session.emergency()) continue;
      require(error == 0);  // D-8: nothing under the overlay
      bool live = false;
      for (const auto& p : session.presses())
        live = live || (p.command == address && p.value == want && now < p.until && joined[slot_of(p.client)] && id[slot_of(p.client)] == p.client &&
                        ended.count({p.client, p.id}) == 0);
      require(live);
    }
    // At most one phone drives, and only the driver holds a drive command.
    for (const auto& p : session.presses())
      if (is_phone_drive(p.command) && kinds[slot_of(p.client)] == ClientKind::phone)
        require(session.driver() == p.client);
  }
  return 0;
}
