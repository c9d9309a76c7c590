// The pages' files (HTML, CSS, JavaScript, SVG), built into the binary from
// web/assets/ by cmake/embed_assets.cmake: nothing to install beside the
// program and nothing fetched from the internet at run time.
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include "rtukit/web/server.hpp"

namespace rtukit::web {

struct Asset {
  std::string_view path;  ///< "/rehand/hmi.html": its path under web/assets/, with a leading '/'
  std::string_view content_type;
  std::string_view body;
};

/// Every embedded file, sorted by path.
std::span<const Asset> assets() noexcept;
/// The file at `path`, or nullptr.
const Asset* find_asset(std::string_view path) noexcept;
/// A 200 response with the file (cached by the browser for an hour), or nullopt.
std::optional<HttpResponse> asset_response(std::string_view path);

}  // namespace rtukit::web
