#include "outputs/device_index_pool.hpp"

namespace cobridge::outputs {

std::optional<std::uint16_t> DeviceIndexPool::acquire(const std::string& key) {
  const std::lock_guard lock(mutex_);
  if (const auto it = taken_.find(key); it != taken_.end()) return it->second;
  std::uint16_t index = 0;
  if (!freed_.empty()) {
    index = freed_.back();
    freed_.pop_back();
  } else if (next_ < kEnd) {
    index = next_++;
  } else {
    return std::nullopt;
  }
  taken_.emplace(key, index);
  return index;
}

void DeviceIndexPool::release(const std::string& key) {
  const std::lock_guard lock(mutex_);
  const auto it = taken_.find(key);
  if (it == taken_.end()) return;
  freed_.push_back(it->second);
  taken_.erase(it);
}

std::size_t DeviceIndexPool::in_use() const {
  const std::lock_guard lock(mutex_);
  return taken_.size();
}

}  // namespace cobridge::outputs
