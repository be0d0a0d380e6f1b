// [redundancy]: the hot-standby pair's settings, and their node-ID checked
// against the devices' (a gateway's heartbeat must not look like a device's).
#include "config/loader.hpp"

#include <algorithm>

namespace cobridge::config::detail {

void Loader::read_redundancy(TableReader& top) {
  const toml::table* t = top.subtable("redundancy");
  if (t == nullptr) return;
  TableReader r(*t, "[redundancy]", "", "redundancy.", sink_);
  r.check_keys({"mode", "node_id", "priority", "heartbeat_ms", "preempt", "hold_s"});
  enum class Mode : std::uint8_t { off, hot_standby };
  const auto mode = r.choice<Mode>("mode", {{"off", Mode::off}, {"hot-standby", Mode::hot_standby}});
  if (!mode) {
    if (r.find("mode") == nullptr) r.error(*t, "[redundancy] needs mode = \"hot-standby\" (or \"off\")");
    return;
  }
  if (*mode == Mode::off) return;
  RedundancySettings s;
  const toml::node* node = r.find("node_id");
  if (node == nullptr) {
    r.error(*t, "[redundancy] needs node_id: this gateway's node-ID on its buses (1..127, unused by any device)");
    return;
  }
  const auto id = r.integer("node_id", 1, 127);
  if (!id) return;
  s.node_id = static_cast<std::uint8_t>(*id);
  redundancy_node_spot_ = location(sink_, *node);
  if (auto v = r.integer("priority", 0, 2)) s.priority = static_cast<std::uint8_t>(*v);
  if (auto v = r.integer("heartbeat_ms", 10, 10000)) s.heartbeat = std::chrono::milliseconds(*v);
  if (auto v = r.boolean("preempt")) s.preempt = *v;
  if (auto v = r.integer("hold_s", 1, 3600)) s.hold = std::chrono::seconds(*v);
  config_.redundancy = s;
}

void Loader::check_redundancy_node() {
  if (!config_.redundancy) return;
  const std::uint8_t node = config_.redundancy->node_id;
  for (const Device& d : config_.devices) {
    if (d.node_id && *d.node_id == node) {
      add(redundancy_node_spot_, "redundancy.node_id " + std::to_string(node) + " is device " + in_quotes(d.name) +
                                     "'s node-ID (" + at(d.where) + "); the gateways need a node-ID of their own");
    }
  }
  for (Bus& b : config_.buses) {
    if (b.node_pool_default) {  // the gateway's own node-ID is never given to a device
      b.node_pool.erase(std::remove(b.node_pool.begin(), b.node_pool.end(), node), b.node_pool.end());
      continue;
    }
    for (const std::uint8_t n : b.node_pool) {
      if (n == node) {
        add(redundancy_node_spot_, "redundancy.node_id " + std::to_string(node) + " is in bus " + in_quotes(b.name) +
                                       "'s node_pool (" + at(b.where) + "); the gateways need a node-ID of their own");
      }
    }
  }
}

}  // namespace cobridge::config::detail
