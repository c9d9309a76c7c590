#include "rtukit/driver/simulation.hpp"

#include <cctype>
#include <charconv>

#include "rtukit/io/asio.hpp"

namespace rtukit {

struct PeriodicTimer::Impl {
  Impl(asio::io_context& ctx, std::chrono::milliseconds p, std::function<void()> t)
      : timer(ctx), period(p), tick(std::move(t)) {}
  void arm() {
    timer.expires_after(period);
    timer.async_wait([this](const boost::system::error_code& ec) {
      if (ec) return;  // cancelled: the owner is going away
      tick();
      arm();
    });
  }
  asio::steady_timer timer;
  std::chrono::milliseconds period;
  std::function<void()> tick;
};

PeriodicTimer::PeriodicTimer(asio::io_context& ctx, std::chrono::milliseconds period,
                             std::function<void()> tick)
    : impl_(std::make_unique<Impl>(ctx, period, std::move(tick))) {
  impl_->arm();
}

PeriodicTimer::~PeriodicTimer() {
  impl_->timer.cancel();
}

std::vector<std::string> split_words(std::string_view line) {
  std::vector<std::string> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) words.emplace_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

std::optional<long> parse_long(std::string_view text, int base) noexcept {
  if (text.starts_with("0x") || text.starts_with("0X")) {
    text.remove_prefix(2);
    base = 16;
  }
  long v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (text.empty() || ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return v;
}

std::optional<double> parse_double(std::string_view text) noexcept {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return v;
}

}  // namespace rtukit
