#include "rtukit/driver/bus_line.hpp"

#include <algorithm>

namespace rtukit {
namespace {

uint64_t ceil_div(uint64_t a, uint64_t b) {
  return (a + b - 1) / b;
}

void clamp_rates(BusConfig& c) {
  const auto clamp01 = [](double& p) { p = std::clamp(p, 0.0, 1.0); };
  clamp01(c.bit_error_rate);
  clamp01(c.drop_rate);
  clamp01(c.stray_rate);
}

}  // namespace

BusLine::BusLine(unsigned ports, BusConfig config)
    : config_(config), next_free_ns_(std::max(1U, ports), 0), rng_(config.seed) {
  clamp_rates(config_);
  config_.baud = std::max(1U, config_.baud);
  char_ns_ = uint64_t{config_.bits_per_char} * 1'000'000'000ULL / config_.baud;
}

void BusLine::set_faults(const BusConfig& faults) {
  config_.bit_error_rate = faults.bit_error_rate;
  config_.drop_rate = faults.drop_rate;
  config_.stray_rate = faults.stray_rate;
  config_.latency_us = faults.latency_us;
  config_.echo = faults.echo;
  config_.echo_ports = faults.echo_ports;
  clamp_rates(config_);
}

bool BusLine::chance(double p) {
  if (p <= 0) return false;
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p;
}

void BusLine::write(unsigned port, std::span<const uint8_t> bytes, uint64_t now_us) {
  if (port >= next_free_ns_.size()) return;
  const uint64_t now_ns = now_us * 1000;
  for (uint8_t b : bytes) {
    // A UART sends its bytes back to back; a write while it is busy queues behind.
    const uint64_t start = std::max(now_ns, next_free_ns_[port]);
    const InAir c{start, start + char_ns_, static_cast<int>(port), b};
    next_free_ns_[port] = c.end_ns;
    const auto at = std::upper_bound(in_air_.begin(), in_air_.end(), c.end_ns,
                                     [](uint64_t end, const InAir& x) { return end < x.end_ns; });
    in_air_.insert(at, c);
  }
}

std::optional<uint64_t> BusLine::next_due() const {
  std::optional<uint64_t> due;
  if (!in_air_.empty()) due = ceil_div(in_air_.front().end_ns, 1000);
  if (!outbox_.empty()) due = due ? std::min(*due, outbox_.front().at_us) : outbox_.front().at_us;
  return due;
}

void BusLine::advance(uint64_t now_us, std::vector<BusDelivery>& out, std::vector<BusCharacter>* tap) {
  const uint64_t now_ns = now_us * 1000;
  while (!in_air_.empty() && in_air_.front().end_ns <= now_ns) {
    const InAir c = in_air_.front();
    in_air_.erase(in_air_.begin());
    finish(c, tap);
  }
  size_t n = 0;
  while (n < outbox_.size() && outbox_[n].at_us <= now_us) out.push_back(outbox_[n++]);
  outbox_.erase(outbox_.begin(), outbox_.begin() + static_cast<std::ptrdiff_t>(n));
}

void BusLine::finish(const InAir& c, std::vector<BusCharacter>* tap) {
  BusCharacter ch{c.start_ns / 1000, c.end_ns / 1000, c.sender, c.byte, c.byte, false, false};
  // Another sender on the line during any part of this character: both are garbage.
  const auto overlaps = [&c](const InAir& d) {
    return d.sender != c.sender && d.start_ns < c.end_ns && c.start_ns < d.end_ns;
  };
  const InAir* other = nullptr;
  for (const InAir& d : in_air_)
    if (overlaps(d)) other = &d;
  for (const InAir& d : recent_)
    if (overlaps(d)) other = &d;
  if (other) {
    ch.collided = true;
    ch.heard = static_cast<uint8_t>(c.byte ^ other->byte ^ 0xA5);
    if (ch.heard == c.byte) ch.heard = static_cast<uint8_t>(~c.byte);
    ++stats_.collisions;
  }
  bool flipped = false;
  for (unsigned bit = 0; bit < 8; ++bit) {
    if (chance(config_.bit_error_rate)) {
      ch.heard = static_cast<uint8_t>(ch.heard ^ (1U << bit));
      flipped = true;
    }
  }
  if (flipped) ++stats_.bit_errors;
  ch.dropped = chance(config_.drop_rate);
  if (ch.dropped) ++stats_.dropped;
  ++stats_.characters;
  stats_.busy_us += char_ns_ / 1000;

  recent_.push_back(c);
  std::erase_if(recent_, [&](const InAir& d) { return d.end_ns + 2 * char_ns_ < c.end_ns; });

  if (!ch.dropped) {
    uint64_t at = ceil_div(c.end_ns, 1000);
    if (config_.latency_us) at = ceil_div(at, config_.latency_us) * config_.latency_us;
    for (unsigned p = 0; p < next_free_ns_.size(); ++p) {
      const bool hears_itself = config_.echo || (p < 32 && ((config_.echo_ports >> p) & 1U) != 0);
      if (static_cast<int>(p) == c.sender && !hears_itself) continue;
      const BusDelivery d{p, ch.heard, at};
      const auto pos = std::upper_bound(outbox_.begin(), outbox_.end(), at,
                                        [](uint64_t t, const BusDelivery& x) { return t < x.at_us; });
      outbox_.insert(pos, d);
    }
  }
  if (tap) tap->push_back(ch);

  // Noise in the silence after a transmission: a byte 4 character times
  // after the line went quiet (past t3.5: between frames, not inside one).
  if (c.sender >= 0 && in_air_.empty() && chance(config_.stray_rate)) {
    const uint64_t start = c.end_ns + 4 * char_ns_;
    in_air_.push_back(InAir{start, start + char_ns_, -1,
                            static_cast<uint8_t>(std::uniform_int_distribution<int>(0, 255)(rng_))});
    ++stats_.stray;
  }
}

}  // namespace rtukit
