// The simulator state file (state_from_text) of each device: the Inverjet,
// the Rehand 6600 and the example map's device, on arbitrary text.
// Properties: never crashes and never throws; all or nothing: a refused file
// leaves the image exactly as it was, and is refused as malformed, bad_crc or
// illegal_data_value with a reason; a loaded image re-serialises
// (state_to_text) to text that loads into a fresh device to the same image.
//
// Input: the device (1 byte), a flag byte, then the text. With flag bit 0 the
// text is "signed" first (when it is a JSON object, its checksum is replaced
// by the right one), so the fuzzer gets past the CRC to the rows' checks.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fuzz_devices.hpp"
#include "rtukit/core/crc.hpp"
#include "rtukit/devices/profile/state_file.hpp"

namespace {

// The file's checksum as state_file.cpp writes it: CRC-16/Modbus over the
// compact dump of "registers", as "0x%04X".
std::string sign(const std::string& text) {
  nlohmann::json file = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!file.is_object() || !file.contains("registers")) return text;
  const std::string regs = file["registers"].dump();
  char crc[8];
  std::snprintf(crc, sizeof crc, "0x%04X",
                rtukit::crc16({reinterpret_cast<const uint8_t*>(regs.data()), regs.size()}));
  file["checksum"] = crc;
  return file.dump();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace rtukit;
  if (size < 2) return 0;
  const unsigned kind = data[0];
  std::string text(reinterpret_cast<const char*>(data + 2), size - 2);
  if (data[1] & 1) text = sign(text);

  std::unique_ptr<profile::Model> model = fuzz::make_device(kind);
  const profile::Profile& p = model->profile();
  profile::Image& image = model->image();
  const std::vector<uint16_t> before(image.words().begin(), image.words().end());
  const Status s = profile::state_from_text(p, text, image);
  if (s) {
    if (!std::equal(before.begin(), before.end(), image.words().begin(), image.words().end())) std::abort();
    if ((s.code() != Errc::malformed && s.code() != Errc::bad_crc && s.code() != Errc::illegal_data_value) ||
        s.reason().empty())
      std::abort();
    return 0;
  }
  const std::string saved = profile::state_to_text(p, image);
  std::unique_ptr<profile::Model> fresh = fuzz::make_device(kind);
  if (profile::state_from_text(p, saved, fresh->image())) std::abort();
  if (!std::equal(image.words().begin(), image.words().end(), fresh->image().words().begin(),
                  fresh->image().words().end()))
    std::abort();
  return 0;
}
