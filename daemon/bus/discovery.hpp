// Discovery: finds the devices on one CAN bus, decides which node-ID each
// must have, and commissions them (moves them there) as the bus's
// commissioning policy allows.
//
// The procedures, as CiA 305 names them, one file pair each under
// bus/discovery/ (each header states the behaviour it implements):
//   identity_probe     finding: who answers SDO 0x1018 at which node-ID,
//                      clashes, boot-ups (identity confirmation);
//   node_assignment    deciding: the target node-ID of each identified device,
//                      swap policy, unknown_devices (a pure function;
//                      decisions applies it to the session);
//   fastscan_search    which Fastscan / Slowscan searches look for FFh devices,
//                      and the strangers they keep finding;
//   commissioning      the jobs (move, clash strategies (a)(b)(c),
//                      non-configured) as LSS/NMT/SDO tasks, one at a time;
//                      clash_resolution.cpp and lss_outcomes.cpp are its parts;
//   lss_families       what each encoder family can do over LSS, and its SDO
//                      node-ID object.
// When probes run: identity_probe.hpp; the commissioning policies and what
// each lets discovery send: commissioning.hpp.
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
#include "bus/device_status.hpp"
#include "bus/state_store.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

namespace cobridge::bus {

enum class DiscoveryEventKind : std::uint8_t {
  identified,      // a device answered the probe at node_id (identity known)
  commissioned,    // a device was moved from previous_node_id to node_id (and stored)
  clash_detected,  // several devices answer at node_id (count = how many seen)
  clash_resolved,  // the clash at node_id has been taken apart: a probe found at most one device left
  problem,         // something an operator must know (text); nothing was changed
  retry,           // commissioning a device failed (text = cause); tried again after retry_in (count = failures)
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
  std::uint32_t count = 0;            // clash: devices seen at node_id (a lower bound); retry: failures so far
  canopen::Duration retry_in{};       // retry: when the next try is due
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
Error record_assignment(StateStore& store, const std::string& bus, const DiscoveryEvent& e);

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
  // While `why` is not empty node-IDs must not be assigned (the state file
  // could not be read, StateStore::hold()): commissioning behaves as policy
  // off, whatever the configuration says (identities are read, nothing is
  // moved, request_commission() is ignored); devices found at the node-ID
  // they must have are still identified at their target. Empty: the bus's
  // policy again. A released hold should start a new Discovery, whose
  // decisions rest on the memory the operator gave back.
  void hold_assignments(std::string why);
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

}  // namespace cobridge::bus
