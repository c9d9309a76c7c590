// rtukit io: the name of our one event-loop library, without its headers.
//
// rtukit uses Boost.Asio, and only Boost.Asio (docs/architecture.md says why:
// Beast, under web/, is built on it, and one io_context can then serve the
// bus worker and the web listeners). Our code calls it `asio::` through the
// alias below, in namespace rtukit. This header declares just io_context, for
// headers that take one by reference; a source file that uses Asio includes
// "rtukit/io/asio.hpp".
#pragma once

namespace boost::asio {
class io_context;
}  // namespace boost::asio

namespace rtukit {
namespace asio = boost::asio;
}  // namespace rtukit
