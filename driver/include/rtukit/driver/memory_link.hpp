// rtukit driver: a link in memory, for testing masters without a port.
//
// Each request written is handed to `respond`, which returns the bytes the
// "device" answers (empty: silence), and how long after the request they
// arrive. Time is a DriverClock (a ManualClock in tests): waiting for an
// answer that never comes moves the clock to the deadline instead of
// sleeping, so retries, timeouts and delays are tested in no real time.
#pragma once

#include <chrono>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <vector>

#include "rtukit/base/clock.hpp"
#include "rtukit/io/link.hpp"

namespace rtukit {

class MemoryLink final : public io::Link {
 public:
  struct Reply {
    std::vector<uint8_t> bytes;             ///< empty: no answer
    std::chrono::microseconds delay{1000};  ///< after the request
  };
  using Responder = std::function<Reply(std::span<const uint8_t> request)>;

  MemoryLink(DriverClock& clock, Responder respond, Framing framing = Framing::rtu)
      : clock_(clock), respond_(std::move(respond)), framing_(framing) {}

  Error open() override {
    open_ = true;
    return {};
  }
  void close() noexcept override { open_ = false; }
  bool is_open() const noexcept override { return open_; }

  Error write(std::span<const uint8_t> bytes, Clock::time_point) override {
    if (!open_) return Errc::not_connected;
    std::lock_guard lock(mutex_);
    writes_.emplace_back(bytes.begin(), bytes.end());
    Reply r = respond_(bytes);
    if (!r.bytes.empty()) pending_.push_back({clock_.now() + r.delay, std::move(r.bytes)});
    return {};
  }

  Result<size_t> read_some(std::span<uint8_t> out, Clock::time_point deadline) override {
    if (!open_) return Errc::not_connected;
    std::unique_lock lock(mutex_);
    if (pending_.empty() || pending_.front().at > deadline) {
      lock.unlock();
      clock_.sleep_until(deadline);  // nothing arrives in time: the deadline passes
      return size_t{0};
    }
    Pending& p = pending_.front();
    lock.unlock();
    clock_.sleep_until(p.at);
    lock.lock();
    const size_t n = std::min(out.size(), p.bytes.size());
    std::memcpy(out.data(), p.bytes.data(), n);
    p.bytes.erase(p.bytes.begin(), p.bytes.begin() + static_cast<std::ptrdiff_t>(n));
    if (p.bytes.empty()) pending_.pop_front();
    return n;
  }

  /// Drops what has arrived by now. An answer still on its way arrives
  /// later, as on a line: flushing the input cannot stop a late answer.
  void discard_input() noexcept override {
    std::lock_guard lock(mutex_);
    const auto now = clock_.now();
    std::erase_if(pending_, [now](const Pending& p) { return p.at <= now; });
  }
  Framing framing() const noexcept override { return framing_; }
  RtuTiming timing() const noexcept override { return {}; }
  std::string describe() const override { return "memory"; }

  /// Every request written, in order.
  std::vector<std::vector<uint8_t>> writes() const {
    std::lock_guard lock(mutex_);
    return writes_;
  }

 private:
  struct Pending {
    Clock::time_point at;
    std::vector<uint8_t> bytes;
  };
  DriverClock& clock_;
  Responder respond_;
  Framing framing_;
  bool open_ = false;
  mutable std::mutex mutex_;
  std::deque<Pending> pending_;
  std::vector<std::vector<uint8_t>> writes_;
};

}  // namespace rtukit
