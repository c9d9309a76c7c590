// Microbenchmarks of the sans-IO core (Google Benchmark): the per-frame costs
// every transport pays.
#include <benchmark/benchmark.h>

#include <array>
#include <vector>

#include "rtukit/core.hpp"

using namespace rtukit;

namespace {

class Bank final : public RegisterBank {
 public:
  std::array<uint16_t, 200> regs{};
  Errc read_holding_registers(uint16_t a, std::span<uint16_t> out) override {
    if (size_t{a} + out.size() > regs.size()) return Errc::illegal_data_address;
    std::copy_n(regs.begin() + a, out.size(), out.begin());
    return Errc::ok;
  }
};

std::vector<uint8_t> read_request(uint16_t quantity) {
  std::array<uint8_t, kMaxPduSize> pdu{};
  const size_t n = *encode_read_request(Function::read_holding_registers, 0, quantity, pdu);
  std::vector<uint8_t> adu(kMaxRtuAduSize);
  adu.resize(*rtu_encode(1, {pdu.data(), n}, adu));
  return adu;
}

void BM_Crc16_256Bytes(benchmark::State& state) {
  std::array<uint8_t, 256> data{};
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 7);
  for (auto _ : state) benchmark::DoNotOptimize(crc16(data));
  state.SetBytesProcessed(state.iterations() * 256);
}
BENCHMARK(BM_Crc16_256Bytes);

void BM_FramerAndEngine_Fc03(benchmark::State& state) {
  const auto request = read_request(static_cast<uint16_t>(state.range(0)));
  Bank bank;
  SlaveEngine engine;
  (void)engine.add_unit(UnitId{1}, bank);
  RtuFramer framer(FrameShape::request);
  std::array<uint8_t, kMaxRtuAduSize> out{};
  for (auto _ : state) {
    framer.feed(request, 0);
    auto frame = framer.next(0);
    benchmark::DoNotOptimize(engine.handle_rtu(frame->adu, out).length);
  }
}
BENCHMARK(BM_FramerAndEngine_Fc03)->Arg(4)->Arg(125);

void BM_MasterParsesResponse_Fc03(benchmark::State& state) {
  const auto q = static_cast<uint16_t>(state.range(0));
  Request r;
  r.function = 0x03;
  r.quantity = q;
  MasterTransaction tx;
  (void)tx.begin(Framing::rtu, UnitId{1}, r);
  std::vector<uint8_t> pdu{0x03, static_cast<uint8_t>(2 * q)};
  pdu.resize(2 + 2 * q, 0x5A);
  std::array<uint8_t, kMaxRtuAduSize> adu{};
  const size_t n = *rtu_encode(1, pdu, adu);
  RtuFramer framer(FrameShape::response);
  std::array<uint16_t, 125> regs{};
  for (auto _ : state) {
    tx.prepare(framer, false);
    framer.feed({adu.data(), n}, 0);
    auto frame = framer.next(0);
    auto outcome = tx.accept_rtu(*frame);
    load_registers((*outcome)->data, {regs.data(), q});
    benchmark::DoNotOptimize(regs);
  }
}
BENCHMARK(BM_MasterParsesResponse_Fc03)->Arg(4)->Arg(125);

}  // namespace

BENCHMARK_MAIN();
