// rtukit base: an error with its reason, as one returned value.
//
// `Error` (core) carries a code and, optionally, a static reason. Host code
// often knows more ("plan line 3: speed 120 is outside 0..100", "port
// /dev/ttyUSB0: permission denied"): `Status` is that Error plus a reason
// built at run time. It converts from Error, so functions returning Status
// can `return Errc::timeout;` or pass a lower layer's Error on.
//
// Callers pick exit codes and UI reactions from `code()`, never from the
// text; the text is for people.
#pragma once

#include <string>
#include <string_view>
#include <utility>

#include "rtukit/core/error.hpp"

namespace rtukit {

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(error) {}  // NOLINT: implicit on purpose
  Status(Errc code) : error_(code) {}     // NOLINT: implicit on purpose
  Status(Error error, std::string reason) : error_(error), reason_(std::move(reason)) {}

  bool ok() const noexcept { return error_.ok(); }
  explicit operator bool() const noexcept { return !ok(); }  // true = failed, as Error
  Error error() const noexcept { return error_; }
  Errc code() const noexcept { return error_.code(); }
  bool is_exception() const noexcept { return error_.is_exception(); }
  int32_t os_error() const noexcept { return error_.os_error(); }
  std::string_view name() const noexcept { return error_.name(); }
  /// The reason given here, else the Error's static reason, else the code's name.
  std::string_view reason() const noexcept {
    return reason_.empty() ? error_.text() : std::string_view(reason_);
  }

  friend bool operator==(const Status& a, Errc b) noexcept { return a.code() == b; }

 private:
  Error error_{};
  std::string reason_;
};

/// A value or a Status.
template <class T>
using Outcome = Result<T, Status>;

}  // namespace rtukit
