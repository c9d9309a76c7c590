// A minimal Modbus-RTU slave firmware for a Cortex-M4: the core's framer and
// slave engine serving 32 holding and 8 input registers at unit 1, 19200 baud.
//
// Built only by the cortex-m4 presets (core/examples/CMakeLists.txt), with
// newlib-nano and unused sections garbage-collected, to measure the flash the
// core takes in a real link (core_size.cmake reads the linker map). The UART
// and the microsecond counter are plain memory-mapped registers at made-up
// addresses: a real firmware reads its own from its HAL or an interrupt.
#include <array>
#include <cstdint>
#include <span>

#include "rtukit/core/rtu.hpp"
#include "rtukit/core/slave.hpp"

namespace {

struct Uart {
  volatile uint32_t status;  // bit 0: a byte received, bit 7: ready to send
  volatile uint32_t data;
};
Uart& uart() {
  return *reinterpret_cast<Uart*>(0x40011000);
}
uint32_t micros() {
  return *reinterpret_cast<volatile uint32_t*>(0x40000024);
}

class Registers final : public rtukit::RegisterBank {
 public:
  rtukit::Errc read_holding_registers(uint16_t address, std::span<uint16_t> out) override {
    if (address + out.size() > holding_.size()) return rtukit::Errc::illegal_data_address;
    for (size_t i = 0; i < out.size(); ++i) out[i] = holding_[address + i];
    return rtukit::Errc::ok;
  }
  rtukit::Errc read_input_registers(uint16_t address, std::span<uint16_t> out) override {
    if (address + out.size() > 8) return rtukit::Errc::illegal_data_address;
    for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint16_t>(micros() >> (address + i));
    return rtukit::Errc::ok;
  }
  rtukit::Errc write_holding_registers(uint16_t address, std::span<const uint16_t> values) override {
    if (address + values.size() > holding_.size()) return rtukit::Errc::illegal_data_address;
    for (size_t i = 0; i < values.size(); ++i) holding_[address + i] = values[i];
    return rtukit::Errc::ok;
  }
  rtukit::FunctionSet functions() const noexcept override {
    using rtukit::Function;
    return rtukit::function_bit(Function::read_holding_registers) |
           rtukit::function_bit(Function::read_input_registers) |
           rtukit::function_bit(Function::write_single_register) |
           rtukit::function_bit(Function::write_multiple_registers);
  }

 private:
  std::array<uint16_t, 32> holding_{};
};

rtukit::SlaveEngine engine;
std::array<uint8_t, rtukit::kMaxRtuAduSize> answer;

}  // namespace

int main() {
  // Locals of a main that never returns: no destructor registered at exit.
  Registers bank;
  rtukit::RtuFramer framer(rtukit::FrameShape::request, rtukit::RtuTiming::for_serial(19200));
  if (engine.add_unit(rtukit::UnitId{1}, bank)) return 1;
  uint64_t now = 0;
  uint32_t last = micros();
  for (;;) {
    const uint32_t t = micros();
    now += t - last;  // a 32-bit counter widened: wraps are differences
    last = t;
    if (uart().status & 1U) {
      const auto byte = static_cast<uint8_t>(uart().data);
      (void)framer.feed({&byte, 1}, now);
    }
    if (const auto frame = framer.next(now)) {
      const rtukit::SlaveEngine::Handled h = engine.handle_rtu(frame->adu, answer);
      for (size_t i = 0; i < h.length; ++i) {
        while (!(uart().status & 0x80U)) {
        }
        uart().data = answer[i];
      }
      if (h.bank != nullptr) h.bank->after_response();
    }
  }
}
