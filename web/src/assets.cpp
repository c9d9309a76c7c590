// Lookup in the generated table (assets_data.cpp).
#include "rtukit/web/assets.hpp"

#include <algorithm>

namespace rtukit::web {

const Asset* find_asset(std::string_view path) noexcept {
  const auto all = assets();
  const auto it = std::lower_bound(all.begin(), all.end(), path,
                                   [](const Asset& a, std::string_view p) { return a.path < p; });
  return it != all.end() && it->path == path ? &*it : nullptr;
}

std::optional<HttpResponse> asset_response(std::string_view path) {
  const Asset* a = find_asset(path);
  if (!a) return std::nullopt;
  return HttpResponse{.status = 200,
                      .content_type = std::string(a->content_type),
                      .body = std::string(a->body),
                      .cache_control = "max-age=3600"};
}

}  // namespace rtukit::web
