// rtukit io: a capture file Wireshark and tshark read (pcap, LINKTYPE_RAW).
//
// Each RTU frame is written as an IPv4 UDP datagram between 10.0.0.1 (the
// master, port 40000) and 10.0.0.2 (the slave, port 502), so
// `tshark -d udp.port==502,mbrtu` decodes it as Modbus RTU. Times are the
// frames' own (microseconds, as the sniffer keeps them).
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>

#include "rtukit/base/status.hpp"

namespace rtukit::term {

class PcapFile {
 public:
  /// pcap's magic number, the first 4 bytes of every capture (little-endian on disk here).
  static constexpr uint32_t kMagic = 0xA1B2C3D4;

  /// Creates `path` and writes the global header (v2.4, snaplen 65535,
  /// LINKTYPE_RAW). An existing capture (the magic number first) is
  /// replaced; any other file only with `overwrite` (create_output_file).
  /// Errors: those of create_output_file (refused, io_error: "cannot create
  /// PATH: ..."), io_error "PATH: cannot write".
  static Outcome<std::unique_ptr<PcapFile>> create(const std::string& path, bool overwrite);
  ~PcapFile();
  PcapFile(const PcapFile&) = delete;
  PcapFile& operator=(const PcapFile&) = delete;

  /// Appends one record: `frame` (the whole RTU ADU) at `time_us`, from the
  /// master when `from_master`, else from the slave. Flushed at once, so a
  /// capture read while it grows is whole up to its last record. Write
  /// errors are not reported (a full disk loses records, not the sniffer).
  void frame(std::span<const uint8_t> frame, uint64_t time_us, bool from_master);

 private:
  explicit PcapFile(std::FILE* out) : out_(out) {}
  void write(const void* data, size_t size);
  std::FILE* out_;
};

}  // namespace rtukit::term
