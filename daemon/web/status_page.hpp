// The status page (/): one self-contained HTML document (inline CSS and
// script, no external fetch: plants are offline) compiled into the binary
// from status_page.html. Its script polls /api/v1/status once a second.
// Thread: any; returns a constant.
#pragma once

#include <string_view>

namespace cobridge::web {

[[nodiscard]] std::string_view status_page_html() noexcept;

}  // namespace cobridge::web
