#include "rtukit/tool/protocol_text.hpp"

#include <fmt/core.h>

#include <iterator>

#include "rtukit/core/pdu.hpp"

namespace rtukit::tool {

std::string comm_event_text(uint8_t event) {
  namespace ce = comm_event;
  if (event == ce::kRestart) return "communications restart";
  if (event == ce::kEnteredListenOnly) return "entered listen-only mode";
  std::string out;
  const auto add = [&](const char* part) {
    if (!out.empty()) out += ", ";
    out += part;
  };
  if (event & ce::kReceive) {
    add((event & ce::kReceiveBroadcast) ? "received broadcast" : "received");
    if (event & ce::kReceiveCommError) add("communication error");
    if (event & ce::kReceiveOverrun) add("character overrun");
    if (event & ce::kListenOnly) add("in listen-only mode");
  } else if (event & ce::kSend) {
    add("sent");
    if (event & ce::kSendReadException) add("read exception");
    if (event & ce::kSendAbortException) add("server abort exception");
    if (event & ce::kSendBusyException) add("busy exception");
    if (event & ce::kSendNakException) add("NAK exception");
    if (event & ce::kSendWriteTimeout) add("write timeout");
    if (event & ce::kListenOnly) add("in listen-only mode");
  } else {
    out = fmt::format("event 0x{:02X}", event);
  }
  return out;
}

namespace {
struct DeviceObjectName {
  const char* name;
  const char* key;
};
constexpr DeviceObjectName kDeviceObjects[] = {
    {"vendor", "vendor"},           {"product code", "product_code"}, {"revision", "revision"},
    {"vendor URL", "vendor_url"},   {"product name", "product_name"}, {"model name", "model_name"},
    {"application", "application"},
};
}  // namespace

const char* device_object_name(uint8_t id) noexcept {
  return id < std::size(kDeviceObjects) ? kDeviceObjects[id].name : nullptr;
}

const char* device_object_key(uint8_t id) noexcept {
  return id < std::size(kDeviceObjects) ? kDeviceObjects[id].key : nullptr;
}

const char* conformity_level_name(uint8_t conformity) noexcept {
  switch (conformity & 0x7F) {
    case static_cast<uint8_t>(DeviceIdAccess::basic):
      return "basic";
    case static_cast<uint8_t>(DeviceIdAccess::regular):
      return "regular";
    case static_cast<uint8_t>(DeviceIdAccess::extended):
      return "extended";
    default:
      return "unknown";
  }
}

}  // namespace rtukit::tool
