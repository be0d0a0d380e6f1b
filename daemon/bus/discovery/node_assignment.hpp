// Node-ID assignment: which node-ID an identified device must have (CiA 305
// leaves this to the LSS master's application). A pure function of what is
// known: the identity found, the bus's configuration, the remembered table
// (state store), what this session decided already and the presence picture
// of the probes. It changes nothing; what the caller must record (a swap, a
// promise given up, a probe to ask for) comes back in Decision::effects.
//
// Deciding. An identified device's target node-ID: the configured device with
// its serial (and vendor/product when the config gives them) -> its node_id,
// else its previous assignment (from the state store), else the next free
// node-ID of the bus's node_pool. An unknown serial of a configured model
// whose configured device is missing takes that device's place when the swap
// policy is same-model. Otherwise an unknown device is reported and left
// alone; a device of the wrong model for its configured serial is reported
// and not configured. A node-ID held by another present device is never
// taken.
//
// Swap (same-model). A configured device (or the replacement that holds its
// place) is
//   present  while the bus manager supervises the node where it was last
//            identified, or a probe found it and no loss was reported since;
//   unsure   when its supervision was lost (set_supervised(node, false)) and
//            its node has not been probed since: that probe is requested at
//            once, and any decision that depends on it waits for it;
//   absent   when a probe of its node got no answer, or it was not found by
//            any probe since start() (after the full start-up probe).
// An unknown serial takes a configured device's place only when exactly one
// configured device of its model is absent and none is unsure; two absent
// ones are reported (which one it replaces is a guess) and left alone. The
// replacement is seen before the old device's loss is known (its boot-up
// comes first, its heartbeat times out later), so every unknown device is
// decided again whenever the presence picture changes (a probe without
// answer, a new identity, a supervision change). A configured serial that
// comes back after a replacement took its place is left alone and reported
// while the replacement is present.
//
// Non-configured (FFh) devices a scan found: the target above; else back to
// the clash node (c) took them from, not stored; else, for a device nobody
// configured under `unknown_devices = "assign"`, its remembered node-ID or the
// next free one of node_pool.
//
// Thread: any; no state, no I/O.
#pragma once

#include "config/config.hpp"
#include "bus/discovery/bus_picture.hpp"
#include "bus/state_store.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace cobridge::bus::discovery {

// A replacement holds configured device `name`'s place (swap policy same-model).
struct Swap {
  std::string name;      // the configured device
  LssAddress by;         // the replacement that holds its place
  LssAddress replaced;   // who held it before (for the state file)
};

// What this discovery session has decided so far.
struct Session {
  std::vector<std::pair<LssAddress, std::uint8_t>> assigned;  // identity -> node-ID promised
  std::vector<Swap> swapped;
};

struct AssignmentInput {
  const config::Bus& bus;
  const std::vector<config::Device>& devices;  // of this bus
  const std::vector<Assignment>& previous;     // the remembered table of this bus
  const BusPicture& picture;
  const Session& session;
  bool initial_probe_done = false;  // every node had its chance to answer since start()
  bool round_active = false;        // a probe round is running: later nodes may still show a device
};

// What the caller records after a decision, in this order.
struct Effects {
  std::optional<LssAddress> forget;  // its node-ID is no longer promised to it
  std::string unswap;                // the swap entry of this configured device ends
  std::optional<Swap> swap;          // a new swap entry
  std::vector<std::uint8_t> probes;  // nodes to probe: the decision waits for them
  bool recheck = false;              // decide again once the running probe round is over
};

struct Decision {
  std::uint8_t target = 0;  // 0 = none: left alone
  std::string device;       // configured name; empty = unknown device
  std::string replaces;     // swap: the configured device whose place it took
  LssAddress replaced;
  std::string problem;      // reported to the operator
  bool wait = false;        // depends on a probe still to come: decide again then
  Effects effects;
};

// The target node-ID of identified device `a` (see above).
[[nodiscard]] Decision decide(const LssAddress& a, const AssignmentInput& in);

// Where a device found non-configured goes. `back_to`: the clash node (c)
// took it from (0 = none). `unknown_policy`: the bus's unknown_devices policy
// applies (a Fastscan find; not a Slowscan find after (c)).
struct Placement {
  enum class Via : std::uint8_t {
    none,      // it stays non-configured
    decision,  // the decision's target
    back,      // back to `back_to`, not stored
    pool,      // unknown_devices = assign: remembered or pool node-ID, stored
  };
  Decision decision;
  Via via = Via::none;
  std::uint8_t target = 0;     // 0 = none
  bool pool_exhausted = false; // unknown_devices = assign, but node_pool has no free node-ID
};
[[nodiscard]] Placement place_non_configured(const LssAddress& a, std::uint8_t back_to, bool unknown_policy,
                                             const AssignmentInput& in);

// Is `node` free for device `a`: no other present device there (nor an
// unpaired clash), and not promised to another device.
[[nodiscard]] bool node_free_for(std::uint8_t node, const LssAddress& a, const BusPicture& picture,
                                 const Session& session);
[[nodiscard]] std::optional<std::uint8_t> assigned_to(const LssAddress& a, const Session& session);
[[nodiscard]] const config::Device* configured_by_serial(std::uint32_t serial,
                                                         const std::vector<config::Device>& devices);
// Does `a` fit configured device c's vendor/product/model? `need_info`: a
// device whose config says nothing about its model fits nothing.
[[nodiscard]] bool model_matches(const config::Device& c, const LssAddress& a, bool need_info);

}  // namespace cobridge::bus::discovery
