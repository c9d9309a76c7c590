// Raw IPv4 + UDP rather than a Modbus RTU link type: tshark has no link type
// for RTU on a serial line, but decodes a UDP port as RTU when told to, and
// every pcap reader understands raw IP. The fields are written in the host's
// byte order, which pcap readers detect from the magic number.
#include "rtukit/term/pcap_file.hpp"

#include <unistd.h>

#include <string_view>
#include <vector>

#include "rtukit/io/atomic_file.hpp"

namespace rtukit::term {

Outcome<std::unique_ptr<PcapFile>> PcapFile::create(const std::string& path, bool overwrite) {
  const uint32_t header[] = {kMagic, 0x00040002, 0,
                             0,      65535,      101};  // magic, v2.4, tz, sigfigs, snaplen, raw IP
  const std::string_view magic(reinterpret_cast<const char*>(header), 4);
  Outcome<int> fd = io::create_output_file(path, magic, overwrite);
  if (!fd.ok()) return fd.error();
  std::FILE* out = ::fdopen(*fd, "wb");
  if (!out) {
    ::close(*fd);
    return Status(Errc::io_error, path + ": cannot write");
  }
  auto file = std::unique_ptr<PcapFile>(new PcapFile(out));
  file->write(header, sizeof header);
  return file;
}

PcapFile::~PcapFile() {
  std::fclose(out_);
}

void PcapFile::frame(std::span<const uint8_t> frame, uint64_t time_us, bool from_master) {
  const size_t udp_len = 8 + frame.size(), ip_len = 20 + udp_len;
  // IPv4: version 4, header 20 bytes, don't fragment, TTL 64, UDP; checksum below.
  std::vector<uint8_t> p{
      0x45, 0, static_cast<uint8_t>(ip_len >> 8), static_cast<uint8_t>(ip_len), 0, 0, 0x40, 0, 64, 17, 0, 0};
  const uint8_t master[] = {10, 0, 0, 1}, slave[] = {10, 0, 0, 2};
  p.insert(p.end(), from_master ? master : slave, (from_master ? master : slave) + 4);
  p.insert(p.end(), from_master ? slave : master, (from_master ? slave : master) + 4);
  uint32_t sum = 0;
  for (size_t i = 0; i < 20; i += 2) sum += static_cast<uint32_t>(p[i] << 8 | p[i + 1]);
  while (sum >> 16) sum = (sum & 0xFFFF) + (sum >> 16);
  p[10] = static_cast<uint8_t>(~sum >> 8);
  p[11] = static_cast<uint8_t>(~sum);
  // UDP without a checksum (0: none, allowed over IPv4).
  const uint16_t sport = from_master ? 40000 : 502, dport = from_master ? 502 : 40000;
  p.insert(p.end(), {static_cast<uint8_t>(sport >> 8), static_cast<uint8_t>(sport),
                     static_cast<uint8_t>(dport >> 8), static_cast<uint8_t>(dport),
                     static_cast<uint8_t>(udp_len >> 8), static_cast<uint8_t>(udp_len), 0, 0});
  p.insert(p.end(), frame.begin(), frame.end());
  const uint32_t record[] = {static_cast<uint32_t>(time_us / 1000000),
                             static_cast<uint32_t>(time_us % 1000000), static_cast<uint32_t>(p.size()),
                             static_cast<uint32_t>(p.size())};
  write(record, sizeof record);
  write(p.data(), p.size());
  std::fflush(out_);
}

void PcapFile::write(const void* data, size_t size) {
  std::fwrite(data, 1, size, out_);
}

}  // namespace rtukit::term
