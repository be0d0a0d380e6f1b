// The vocabulary of commissioning: one step of LSS, NMT or SDO work (a Task)
// about one device (its Ctx), queued by the procedures (move, clash
// resolution, Fastscan search) and run one at a time by Commissioning,
// because the LSS channel serves one operation at a time.
//
// Thread: the bus's control thread.
#pragma once

#include "canopen/clock.hpp"
#include "canopen/lss.hpp"
#include "canopen/nmt.hpp"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace cobridge::bus::discovery {

using canopen::LssAddress;

// The device a task is about and where it must go.
struct Ctx {
  LssAddress identity;
  std::uint8_t from = 0;    // where it is (0xFF = non-configured)
  std::uint8_t target = 0;  // where it must be
  std::string device;       // configured name; empty = unknown device
  std::string replaces;
  LssAddress replaced;
  bool store = true;        // LSS store configuration (not when it is only put back)
  bool boot_wait = true;    // wait for its boot-up at the target
  bool sdo_fallback = false;  // no LSS answer: set the node-ID by SDO (lss_families)
  // Switch selective: identities to try in turn (when the probe could not
  // pair the answers up: vendor/product from the config or its model,
  // every revision the probe saw).
  std::vector<LssAddress> candidates;
  // The tasks of one device share a group: a failure drops the rest.
  int group = 0;
};

[[nodiscard]] inline std::string who(const Ctx& c) {
  return c.device.empty() ? "serial " + std::to_string(c.identity.serial) : c.device;
}

enum class Op : std::uint8_t {
  switch_selective,
  slowscan_one,     // (a) with the revision unknown: exact serial, any revision
  slowscan_loop,    // (b) every device of one vendor/product in the clash
  configure_id,
  store,
  global,
  nmt,
  settle,
  identify_non_configured,
  fastscan_loop,
  fastscan_known,   // a configured device's identity confirmed at FFh (CiA 305 Fastscan, BitChecked 0)
  restore_known,
  check_remaining,  // after (a)/(b): anything left at the clash node -> (c)
  sdo_write,
  wait_boots,
  job_end,
};

struct Task {
  Op op = Op::settle;
  Ctx ctx;
  canopen::LssRange range;
  canopen::LssMode mode = canopen::LssMode::kWaiting;
  canopen::NmtCommand cmd = canopen::NmtCommand::reset_comm;
  std::uint8_t node = 0;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint32_t value = 0;
  std::uint8_t len = 0;
  canopen::Duration duration{};
  std::uint8_t attempts = 0;
  bool non_configured = false;  // slowscan_loop in (c): what it finds has no node-ID now
};

[[nodiscard]] inline Task make(Op op, Ctx ctx = {}) {
  Task t;
  t.op = op;
  t.ctx = std::move(ctx);
  return t;
}
[[nodiscard]] inline Task global_task(canopen::LssMode m, int group = 0) {
  Task t = make(Op::global);
  t.mode = m;
  t.ctx.group = group;
  return t;
}
[[nodiscard]] inline Task nmt_task(canopen::NmtCommand c, std::uint8_t node, int group = 0) {
  Task t = make(Op::nmt);
  t.cmd = c;
  t.node = node;
  t.ctx.group = group;
  return t;
}
// The device-level sequence once a device is in LSS configuration state.
[[nodiscard]] inline std::vector<Task> assign_tasks(const Ctx& c) {
  std::vector<Task> v;
  v.push_back(make(Op::configure_id, c));
  if (c.store) v.push_back(make(Op::store, c));
  v.push_back(global_task(canopen::LssMode::kWaiting, c.group));
  return v;
}

}  // namespace cobridge::bus::discovery
