#include "pipeline/device_table.hpp"

namespace cobridge::pipeline {

void DeviceTable::publish(const DecodePlan& plan) {
  if (plan.node_id == 0 || plan.node_id >= kNodes) return;
  std::lock_guard lock(mutex_);
  plans_[plan.node_id] = plan;
  generation_.fetch_add(1, std::memory_order_release);
}

void DeviceTable::publish_index(std::uint8_t node_id, std::uint16_t device_index) {
  if (node_id == 0 || node_id >= kNodes) return;
  std::lock_guard lock(mutex_);
  DecodePlan& p = plans_[node_id];
  if (p.indexed && p.device_index == device_index) return;
  if (p.device_index != device_index) p = DecodePlan{};  // another device's decoding is not this one's
  p.node_id = node_id;
  p.device_index = device_index;
  p.indexed = true;
  generation_.fetch_add(1, std::memory_order_release);
}

void DeviceTable::remove(std::uint8_t node_id) {
  if (node_id == 0 || node_id >= kNodes) return;
  std::lock_guard lock(mutex_);
  plans_[node_id] = DecodePlan{};
  generation_.fetch_add(1, std::memory_order_release);
}

void DeviceTable::snapshot(Plans& out, std::uint32_t& generation) const {
  std::lock_guard lock(mutex_);
  out = plans_;
  generation = generation_.load(std::memory_order_relaxed);
  snapshots_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace cobridge::pipeline
