// rtukit io: Boost.Asio, as `rtukit::asio` (rtukit/io/asio_fwd.hpp says why
// Boost's flavour and no other).
//
// Completion handlers get a boost::system::error_code: compare it with
// asio::error::* as a boost::system::error_code, never after converting it to
// a std::error_code (Boost's error enums are not std's, and a converted code's
// category is not Boost's). Errors leave our APIs as Error / Status (with the
// errno, if any, in os_error()), so no error_code of either kind is part of a
// public interface; the io_context& the servers run on is the one Boost type.
#pragma once

// Boost 1.74's asio/awaitable.hpp (compiled in C++20, where coroutines are
// on) calls std::exchange without including <utility>; GCC 12's headers no
// longer bring it in on the way, so it is included here, first.
#include <utility>
// clang-format off: <utility> must stay before Boost.Asio
#include <boost/asio.hpp>
// clang-format on

#include "rtukit/io/asio_fwd.hpp"
