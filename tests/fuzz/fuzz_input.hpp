// FuzzInput: reads typed values off the front of a fuzzer's byte string, so a
// target can turn arbitrary bytes into a sequence of actions. Out of bytes,
// every read gives 0 and empty() is true.
// Thread: test code, single-threaded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>

namespace cobridge::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) noexcept : data_(data), size_(size) {}

  [[nodiscard]] bool empty() const noexcept { return pos_ >= size_; }
  std::uint8_t u8() noexcept { return empty() ? 0 : data_[pos_++]; }
  std::uint32_t u32() noexcept {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(u8()) << (8 * i);
    return v;
  }
  // Up to n bytes into out (the rest zero); returns how many were read.
  std::size_t bytes(std::uint8_t* out, std::size_t n) noexcept {
    std::memset(out, 0, n);
    std::size_t k = 0;
    while (k < n && !empty()) out[k++] = data_[pos_++];
    return k;
  }
  [[nodiscard]] std::string_view rest() const noexcept {
    return empty() ? std::string_view{} : std::string_view(reinterpret_cast<const char*>(data_ + pos_), size_ - pos_);
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace cobridge::fuzz
