// The pcap file the sniffer writes, byte for byte: the global header and a
// record (IPv4 + UDP around the RTU frame), as Wireshark reads them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "rtukit/term/pcap_file.hpp"

namespace rtukit::term {
namespace {

struct PcapFileTest : ::testing::Test {
  void SetUp() override {
    if constexpr (std::endian::native != std::endian::little)
      GTEST_SKIP() << "expected bytes are little-endian";
    dir = std::filesystem::temp_directory_path() / ("rtukit-pcap-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
  std::vector<uint8_t> contents(const std::filesystem::path& p) const {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  std::filesystem::path dir;
};

TEST_F(PcapFileTest, GlobalHeaderThenOneRecordByteForByte) {
  const std::filesystem::path path = dir / "line.pcap";
  {
    Outcome<std::unique_ptr<PcapFile>> f = PcapFile::create(path, false);
    ASSERT_TRUE(f.ok()) << f.error().reason();
    const std::vector<uint8_t> request{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
    (*f)->frame(request, 1'700'000'000'250'000, /*from_master=*/true);
  }
  const std::vector<uint8_t> expected{
      // Global header: magic, version 2.4, time zone 0, sigfigs 0, snaplen 65535, LINKTYPE_RAW (101).
      0xD4, 0xC3, 0xB2, 0xA1, 0x02, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,  //
      0xFF, 0xFF, 0x00, 0x00, 0x65, 0x00, 0x00, 0x00,                                                  //
      // Record: seconds 1700000000, microseconds 250000, 36 bytes captured, 36 on the wire.
      0x00, 0xF1, 0x53, 0x65, 0x90, 0xD0, 0x03, 0x00, 0x24, 0x00, 0x00, 0x00, 0x24, 0x00, 0x00, 0x00,  //
      // IPv4: length 36, don't fragment, TTL 64, UDP, checksum 0x26C7, 10.0.0.1 -> 10.0.0.2.
      0x45, 0x00, 0x00, 0x24, 0x00, 0x00, 0x40, 0x00, 0x40, 0x11, 0x26, 0xC7, 0x0A, 0x00, 0x00, 0x01,  //
      0x0A, 0x00, 0x00, 0x02,                                                                          //
      // UDP: 40000 -> 502, length 16, no checksum; then the RTU frame.
      0x9C, 0x40, 0x01, 0xF6, 0x00, 0x10, 0x00, 0x00,  //
      0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
  EXPECT_EQ(contents(path), expected);
}

TEST_F(PcapFileTest, AnAnswerGoesFromTheSlave) {
  const std::filesystem::path path = dir / "answer.pcap";
  {
    Outcome<std::unique_ptr<PcapFile>> f = PcapFile::create(path, false);
    ASSERT_TRUE(f.ok()) << f.error().reason();
    (*f)->frame(std::vector<uint8_t>{0x01, 0x83, 0x02, 0xC0, 0xF1}, 0, /*from_master=*/false);
  }
  const std::vector<uint8_t> bytes = contents(path);
  ASSERT_EQ(bytes.size(), 24U + 16U + 20U + 8U + 5U);
  const size_t ip = 24 + 16, udp = ip + 20;
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin() + ip + 12, bytes.begin() + ip + 20),
            (std::vector<uint8_t>{10, 0, 0, 2, 10, 0, 0, 1}));
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin() + udp, bytes.begin() + udp + 4),
            (std::vector<uint8_t>{0x01, 0xF6, 0x9C, 0x40}));
}

TEST_F(PcapFileTest, ReplacesACaptureButNoOtherFileWithoutOverwrite) {
  const std::filesystem::path capture = dir / "old.pcap", notes = dir / "notes.txt";
  { ASSERT_TRUE(PcapFile::create(capture, false).ok()); }
  EXPECT_TRUE(PcapFile::create(capture, false).ok());
  std::ofstream(notes) << "not a capture\n";
  const Outcome<std::unique_ptr<PcapFile>> refused = PcapFile::create(notes, false);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code(), Errc::refused);
  EXPECT_EQ(contents(notes).size(), 14U);
  EXPECT_TRUE(PcapFile::create(notes, true).ok());
  EXPECT_EQ(contents(notes).size(), 24U);
}

}  // namespace
}  // namespace rtukit::term
