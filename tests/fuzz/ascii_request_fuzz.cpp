// Fuzz target: the CiA 309-3 ASCII gateway's request parser
// (daemon/gateway/remote/ascii_request.*). Any line gives a request or one
// of the standard's error numbers; a read answer is formatted for every type.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "gateway/remote/ascii_request.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cobridge::gateway;
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  const auto r = parse_ascii_request(line);
  if ((r.kind == AsciiRequest::Kind::invalid) == (r.error == AsciiError::none)) std::abort();
  for (int t = 0; t <= static_cast<int>(AsciiType::os); ++t)
    (void)ascii_format(static_cast<AsciiType>(t), std::span<const std::uint8_t>(data, size < 16 ? size : 16));
  return 0;
}
