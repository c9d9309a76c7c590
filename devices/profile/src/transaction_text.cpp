#include "rtukit/devices/profile/transaction_text.hpp"

#include <fmt/format.h>

#include <vector>

#include "rtukit/core/pdu.hpp"
#include "rtukit/devices/profile/register_map.hpp"
#include "rtukit/devices/profile/text.hpp"

namespace rtukit::profile {
namespace {

std::vector<uint16_t> be_words(std::span<const uint8_t> bytes) {
  std::vector<uint16_t> words(bytes.size() / 2);
  load_registers(bytes, words);
  return words;
}

}  // namespace

std::string named_values(const Profile& profile, Space space, uint16_t address,
                         std::span<const uint16_t> words) {
  const RegisterMap map(profile.rows);
  std::string out;
  for (size_t i = 0; i < words.size();) {
    const Slot s = map.at(space, static_cast<uint16_t>(address + i));
    if (!s || s.word != 0 || i + s.row->words() > words.size()) {
      out += fmt::format("{}0x{:04X} = {}", out.empty() ? "" : ", ", address + i, words[i]);
      ++i;
      continue;
    }
    const int64_t raw = RegisterMap::decode(*s.row, words.subspan(i, s.row->words()));
    const std::string key =
        s.row->repeat > 1 ? fmt::format("{}[{}]", s.row->key, s.index) : std::string(s.row->key);
    out += fmt::format("{}{} = {}", out.empty() ? "" : ", ", key, format_value(*s.row, raw));
    i += s.row->words();
  }
  return out;
}

std::string transaction_text(const SniffedTransaction& t, const UnitProfiles& profiles) {
  if (!t.request)
    return fmt::format("garbage ({} bytes: {})", t.response->bytes.size(), hex(t.response->bytes));
  const SniffedFrame& q = *t.request;
  const uint8_t unit = q.unit(), function = q.function();
  const auto found = profiles.find(unit);
  const Profile* p = found == profiles.end() ? nullptr : found->second;
  const Result<Request> req = decode_request(q.pdu(), FrameQuirks{.fc10_without_byte_count = true});
  std::string what;
  if (!req.ok()) {
    what = fmt::format("FC{:02X} {}", function, hex(q.pdu()));
  } else if (function == 0x05 || function == 0x06 || function == 0x0F || function == 0x10) {
    std::vector<uint16_t> values;
    if (function == 0x06) values = {req->value};
    if (function == 0x10) values = be_words(req->data);
    if (p && (function == 0x06 || function == 0x10))
      what = "write " + named_values(*p, Space::holding, req->address, values);
    else if (function == 0x05)
      what = fmt::format("write coil {} = {}", req->address, req->value ? "on" : "off");
    else if (function == 0x0F)
      what = fmt::format("write {} coils at {}", req->quantity, req->address);
    else
      what = fmt::format("write 0x{:04X} = {}", req->address, fmt::join(values, " "));
  } else if (is_read_function(function)) {
    what = fmt::format("read {} 0x{:04X} x{}", space_name(space_of_function(function)), req->address,
                       req->quantity);
  } else if (function == 0x16) {
    what = fmt::format("mask write 0x{:04X} AND 0x{:04X} OR 0x{:04X}", req->address, req->and_mask,
                       req->or_mask);
  } else if (function == 0x17) {
    what = fmt::format("write 0x{:04X} = {}, then read holding 0x{:04X} x{}", req->write_address,
                       fmt::join(be_words(req->data), " "), req->address, req->quantity);
  } else if (function == 0x08) {
    what = fmt::format("diagnostics, sub-function 0x{:04X}", req->sub_function);
  } else if (function == 0x2B) {
    what =
        fmt::format("read device identification, code {}, object 0x{:02X}", req->read_code, req->object_id);
  } else {
    what = function_name(function);  // 07, 0B, 0C, 11: no fields
  }
  std::string line = fmt::format("{:>3} {}", unit == 0 ? std::string("all") : std::to_string(unit), what);
  if (t.broadcast()) return line + " (broadcast)";
  if (!t.response) return line + " -> no response";
  const SniffedFrame& r = *t.response;
  if (!r.crc_ok) return line + fmt::format(" -> CRC error ({})", hex(r.bytes));
  if (r.function() & 0x80) {
    const uint8_t code = r.pdu().size() >= 2 ? r.pdu()[1] : 0;
    return line + fmt::format(" -> exception {:02X} ({})", code, Error::exception(code).name());
  }
  if (req.ok() && function >= 0x01 && function <= 0x04 && r.pdu().size() >= 2) {
    std::span<const uint8_t> data = r.pdu().subspan(2);
    if (function == 0x03 || function == 0x04) {
      if (data.size() == static_cast<size_t>(req->quantity) * 2 + 1)
        data = data.subspan(1);  // 2-byte count form
      const std::vector<uint16_t> words = be_words(data);
      return line + ": " +
             (p ? named_values(*p, space_of_function(function), req->address, words)
                : fmt::format("{}", fmt::join(words, " ")));
    }
    std::string bits;
    for (unsigned i = 0; i < req->quantity; ++i) bits += (data[i / 8] >> (i % 8)) & 1 ? '1' : '0';
    return line + ": " + bits;
  }
  return line + ": ok";
}

}  // namespace rtukit::profile
