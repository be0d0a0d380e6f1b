// Discovery: finds the devices on one CAN bus, decides which node-ID each
// must have, and commissions them (moves them there) as the bus's
// commissioning policy allows.
//
// Finding. A device already on a node-ID shows itself by its boot-up
// (0x700+id `00`), its heartbeat, or by answering an SDO probe of
// 0x1018/1..4 (vendor, product, revision, serial). The probe is raw SDO
// upload frames sent to many node-IDs at once, so that several answers to one
// request are seen: two different answers = two devices on one node-ID (a
// clash). Probes run: all node-IDs 1..127 at start(), then every
// `discovery_period_s` for the node-IDs the bus manager does not supervise
// (set_supervised), at once for a node whose supervision is turned off
// (heartbeat lost: is the device still there?), and on every boot-up (which
// re-identifies a restarted device, so a swapped part never silently
// inherits the old one's settings).
// Two boot-ups from one node-ID within `bootup_clash_window` are a clash too.
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
// Commissioning (policy automatic; manual only after request_commission();
// never when off, where the component only listens and reads identities by
// SDO upload of 0x1018: no LSS, no NMT, no SDO download; with the bus's
// `discovery = false` it sends nothing at all). Probes and commissioning never
// overlap: probes wait while commissioning runs and vice versa.
//   * wrong node-ID: LSS switch selective (identity from the probe),
//     configure node-ID, store, switch global waiting, NMT reset-communication
//     to the old node-ID, wait for the boot-up on the new one. No LSS answer
//     (ifm, whose LSS is undocumented) -> SDO fallback: node-ID object
//     (ifm 0x3000 = id - 1, Novotechnik 0x2000 = id), 'save' to 0x1010, NMT
//     reset node.
//   * clash: (a) switch selective for each clashing device whose identity is
//     known (serials from the probe; vendor/product from the probe, else from
//     the config's vendor/product or its model's; revision from the probe,
//     every one it saw tried in turn, else found by Slowscan over
//     [0, 0xFFFFFFFF]); (b) Slowscan over the serial range for pre-Fastscan
//     devices (Novotechnik rotary, vendor 0x182 products
//     0x0BE0/0x0BF3/0x0BBD/0x0BCD/0x0BE1); (c) otherwise every device is made
//     non-configured (switch global configuration, configure node-ID FFh, not
//     stored, switch global waiting, NMT reset-communication all), then found
//     one by one with Fastscan, and the pre-Fastscan ones of the clash with
//     Slowscan; devices known before keep their node-IDs. Then NMT
//     reset-communication and wait for boot-ups. The clash is resolved
//     (clash_resolved) only when the probe of the clash node that follows
//     finds one device or none there; if several still answer, the next
//     strategy runs: first (a)+(b)+(c) for what is left, then (b) for every
//     pre-Fastscan product seen + (c) for the rest, then (c) for everyone;
//     after that a problem says it could not be resolved.
//   * non-configured devices (FFh) are found by Fastscan (only CiA 305 V3
//     slaves answer), assigned and stored; when identify non-configured is
//     answered but Fastscan finds nobody, Slowscan over the pre-Fastscan
//     products looks for them (devices found that hold a node-ID are left).
// Each step is timed (StepTiming; `at` is left for the caller to stamp,
// because this component reads no clock).
//
// Output: a queue of DiscoveryEvent (take_events()). The bus manager stores
// assignments from `commissioned` (and from `identified` with at_target)
// through record_assignment(), and configures a device only after an
// `identified` event with at_target = true for its node-ID (also after a
// reboot: every boot-up is followed by one). Event texts do not name the bus
// (the bus manager's log lines and status do).
//
// Thread: the bus's control thread (the bus manager's), like every protocol
// component: no threads, no clock reads, no sockets; `now` is passed in and
// process(now) returns the next deadline. Frames go out through the sink.
// Allocates off the per-frame path only (events, decisions); on_frame() does
// not allocate.
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss.hpp"
#include "config/config.hpp"
#include "gateway/device_status.hpp"
#include "gateway/state_store.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

namespace cobridge::gateway {

enum class DiscoveryEventKind : std::uint8_t {
  identified,      // a device answered the probe at node_id (identity known)
  commissioned,    // a device was moved from previous_node_id to node_id (and stored)
  clash_detected,  // several devices answer at node_id (count = how many seen)
  clash_resolved,  // the clash at node_id has been taken apart: a probe found at most one device left
  problem,         // something an operator must know (text); nothing was changed
};
[[nodiscard]] const char* to_string(DiscoveryEventKind k) noexcept;

struct DiscoveryEvent {
  DiscoveryEventKind kind = DiscoveryEventKind::problem;
  std::uint8_t node_id = 0;           // where the device is now / the clashing node-ID
  std::uint8_t previous_node_id = 0;  // commissioned: where it was (0xFF = non-configured)
  std::uint8_t target_node_id = 0;    // identified: where it must be (0 = none: left alone)
  bool at_target = false;             // identified: node_id == target_node_id
  bool boot_up = false;               // identified: the probe followed a boot-up (device restarted)
  canopen::LssAddress identity;       // all zero when unknown (clash, some problems)
  std::string device;                 // configured device name; empty = unknown device
  std::string replaces;               // swap: the configured device whose place it took
  canopen::LssAddress replaced;       // swap: who held that place before (revision 0 when unknown;
                                      // vendor/product 0 when never seen and not configured)
  std::uint32_t count = 0;            // clash: devices seen at node_id (a lower bound)
  std::string text;                   // human-readable, for logs and `cobridge status` problems
};

// What an event means for the state file of bus `bus`: `commissioned`, and
// `identified` at its target, put the device's node-ID (keeping the
// fingerprint already stored for its identity, so an unchanged device is not
// rewritten, and none for a replacement, which must be configured in full);
// a swap (`replaces` set) also erases the line of the device it replaced, so
// that neither a restart nor the pool gives the old device's place back to
// it. Other events change nothing. Returns the first StateStore error.
// Called by the bus manager on its control thread (file I/O).
std::error_code record_assignment(StateStore& store, const std::string& bus, const DiscoveryEvent& e);

struct DiscoveryOptions {
  // Overrides of the bus's lss_timeout_ms / sdo_timeout_ms (0 = take the config's).
  canopen::Duration lss_timeout{};
  canopen::Duration sdo_timeout{};
  // A probe round ends this long after the last answer once every addressed
  // node answered (a second device's answer must have a chance to arrive), at
  // the latest after the SDO timeout.
  canopen::Duration probe_settle = std::chrono::milliseconds(20);
  // Two boot-ups from one node-ID closer than this = two devices.
  canopen::Duration bootup_clash_window = std::chrono::milliseconds(500);
  // How long to wait for the boot-up at the new node-ID after a reset.
  canopen::Duration bootup_timeout = std::chrono::seconds(3);
  // How many frames may be sent in one go before waiting for the next
  // process() call (keeps the kernel transmit queue from overflowing).
  std::uint32_t burst = 32;
};

class Discovery {
 public:
  // Copies what it needs from the bus `bus_index` of `config` and its
  // devices. `previous` = StateStore::on_bus(bus name): earlier assignments.
  Discovery(can::FrameSink& sink, const config::Config& config, std::size_t bus_index,
            std::vector<Assignment> previous = {}, DiscoveryOptions options = {});
  ~Discovery();
  Discovery(const Discovery&) = delete;
  Discovery& operator=(const Discovery&) = delete;

  // Starts: the full probe of 1..127 (if the bus's discovery is on), then
  // periodic probes. Before start() the component only listens.
  void start(canopen::TimePoint now);
  // Feed every received frame (it consumes none: the heartbeat consumer and
  // SDO clients still need them). Returns true when the frame was of use here.
  bool on_frame(const can::Frame& frame, canopen::TimePoint now) noexcept;
  // Runs timeouts and the commissioning steps; returns the next deadline.
  canopen::TimePoint process(canopen::TimePoint now);

  // `cobridge commission`: commission now, whatever the policy except off.
  void request_commission();
  // SIGHUP: new devices/policy; running work finishes under the old settings.
  // The LSS timeout stays as constructed.
  void reload(const config::Config& config, std::size_t bus_index, std::vector<Assignment> previous);
  // The bus manager supervises (configures/heartbeats) this node: periodic
  // probes leave it alone. Boot-ups are still followed by a probe. Turning
  // supervision off (heartbeat lost, device offline) probes the node at once
  // and decides the unknown devices again (see Swap above).
  void set_supervised(std::uint8_t node_id, bool supervised) noexcept;

  // Events since the last call, oldest first.
  [[nodiscard]] std::vector<DiscoveryEvent> take_events();
  // Step timings since the last call, oldest first (`at` not set).
  [[nodiscard]] std::vector<StepTiming> take_timings();

  // True while LSS/NMT commissioning that may reset configured devices is
  // under way (moves, clashes): the bus manager should not start SDO
  // configuration, and should expect boot-ups and silence. A search for
  // non-configured devices (FFh) alone does not count.
  [[nodiscard]] bool commissioning() const noexcept;
  // True while there is anything to commission that the policy holds back
  // (manual: waiting for request_commission()).
  [[nodiscard]] bool commission_pending() const noexcept;

  // What is known per node-ID, for status and tests.
  struct NodeView {
    std::uint8_t node_id = 0;
    std::vector<canopen::LssAddress> identities;  // >1 = clash (as far as the probe could tell)
    std::uint8_t target_node_id = 0;              // of identities[0]; 0 = none
    std::string device;                           // configured name of identities[0]
  };
  [[nodiscard]] std::vector<NodeView> nodes() const;

 private:
  struct Impl;
  // Held by pointer so the header stays small for the bus manager; the
  // implementation is private to discovery.cpp.
  std::unique_ptr<Impl> impl_;
};

}  // namespace cobridge::gateway
