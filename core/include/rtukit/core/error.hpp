// rtukit core: the one error type of the whole stack.
//
// Every operation that can fail returns an `Error` (or a `Result<T>` that holds
// either a value or an `Error`). Codes 0x01..0xFF are Modbus exception codes
// exactly as they travel on the wire, so a slave can answer with
// `static_cast<uint8_t>(code)` and a master reports what the device said
// without translation. Local failures (timeout, CRC, transport) live above
// 0xFF so the two families never collide. No errno, no exceptions, no heap.
#pragma once

#include <cstdint>
#include <string_view>
#include <type_traits>
#include <utility>

namespace rtukit {

enum class Errc : uint16_t {
  ok = 0,
  // Modbus exception codes (Modbus Application Protocol v1.1b3, section 7).
  illegal_function = 0x01,
  illegal_data_address = 0x02,
  illegal_data_value = 0x03,
  server_device_failure = 0x04,
  acknowledge = 0x05,
  server_device_busy = 0x06,
  memory_parity_error = 0x08,
  gateway_path_unavailable = 0x0A,
  gateway_target_failed = 0x0B,
  // Local failures: never sent on the wire.
  timeout = 0x100,      ///< no complete response before the deadline
  bad_crc,              ///< a frame whose CRC does not match its bytes
  malformed,            ///< too short, inconsistent length fields, bad MBAP header
  unexpected_response,  ///< a valid frame that does not answer the request sent
  invalid_argument,     ///< the caller asked for something the protocol cannot carry
  buffer_too_small,     ///< an output span cannot hold the result
  io_error,             ///< the transport failed; `Error::os_error` says why
  not_connected,        ///< the transport is closed (and could not be reopened)
  refused,              ///< a local rule or precondition refused the request (nothing was sent)
};

/// Name of a code, e.g. "illegal data address" or "timeout". Never empty.
std::string_view errc_name(Errc code) noexcept;

/// A failure (or success) as a value. Trivially copyable, 16 bytes.
///
/// A failure may carry a reason: a static text that says why in the terms of
/// the rule that refused ("not while charging"). Reasons must have static
/// storage duration (string literals); text built at run time travels in a
/// `Status` (rtukit/base/status.hpp) on the host side.
class [[nodiscard]] Error {
 public:
  constexpr Error() noexcept = default;
  constexpr Error(Errc code, int32_t os_error = 0) noexcept  // NOLINT: implicit on purpose
      : code_(code), os_error_(os_error) {}
  /// `reason`: a string literal (or other static text), or nullptr.
  constexpr Error(Errc code, const char* reason) noexcept : code_(code), reason_(reason) {}

  /// A local rule refused the request (Errc::refused) for `reason` (static text).
  static constexpr Error refused(const char* reason) noexcept { return Error(Errc::refused, reason); }

  /// A Modbus exception received from (or to be sent by) a slave.
  static constexpr Error exception(uint8_t exception_code) noexcept {
    return Error(static_cast<Errc>(exception_code));
  }

  constexpr Errc code() const noexcept { return code_; }
  constexpr bool ok() const noexcept { return code_ == Errc::ok; }
  constexpr explicit operator bool() const noexcept { return !ok(); }  // true = failed
  /// True when the code is a Modbus exception code (0x01..0xFF).
  constexpr bool is_exception() const noexcept {
    return code_ != Errc::ok && static_cast<uint16_t>(code_) <= 0xFF;
  }
  /// The exception byte as sent on the wire. Precondition: is_exception().
  constexpr uint8_t exception_code() const noexcept { return static_cast<uint8_t>(code_); }
  /// For io_error: the operating system's error number (errno value); else 0.
  constexpr int32_t os_error() const noexcept { return os_error_; }
  std::string_view name() const noexcept { return errc_name(code_); }
  /// The reason given when the error was made, or empty.
  constexpr std::string_view reason() const noexcept {
    return reason_ ? std::string_view(reason_) : std::string_view();
  }
  /// The reason if there is one, else the code's name.
  constexpr std::string_view text() const noexcept { return reason_ ? std::string_view(reason_) : name(); }

  friend constexpr bool operator==(Error a, Error b) noexcept { return a.code_ == b.code_; }
  friend constexpr bool operator==(Error a, Errc b) noexcept { return a.code_ == b; }

 private:
  Errc code_ = Errc::ok;
  int32_t os_error_ = 0;
  const char* reason_ = nullptr;
};

/// Either a value or an error (`Error`, or `Status` on the host side, which
/// adds a reason built at run time). `T` must be default-constructible (it is
/// for every type the stack returns); that keeps this free of unions and
/// placement new.
template <class T, class E = Error>
class [[nodiscard]] Result {
 public:
  constexpr Result(T value) noexcept(noexcept(T(std::move(value))))  // NOLINT: implicit
      : value_(std::move(value)) {}
  constexpr Result(E error) noexcept : error_(std::move(error)) {}  // NOLINT: implicit
  constexpr Result(Errc code) noexcept : error_(code) {}            // NOLINT: implicit
  /// A Result with another error type whose error converts (Error -> Status).
  template <class E2>
  requires(!std::is_same_v<E, E2> &&
           std::is_convertible_v<E2, E>) constexpr Result(Result<T, E2> other) noexcept  // NOLINT: implicit
      : value_(std::move(other.value())), error_(other.error()) {}

  constexpr bool ok() const noexcept { return error_.ok(); }
  constexpr explicit operator bool() const noexcept { return ok(); }  // true = has value
  constexpr const E& error() const noexcept { return error_; }
  /// Precondition: ok().
  constexpr const T& value() const& noexcept { return value_; }
  constexpr T& value() & noexcept { return value_; }
  constexpr const T& operator*() const noexcept { return value_; }
  constexpr T& operator*() noexcept { return value_; }
  constexpr const T* operator->() const noexcept { return &value_; }
  constexpr T* operator->() noexcept { return &value_; }

 private:
  T value_{};
  E error_{};
};

}  // namespace rtukit
