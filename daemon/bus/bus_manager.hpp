// BusManager: everything the gateway does on one CAN bus except the hot path.
//
// It discovers the devices (boot-up, heartbeat, SDO probe of 0x1018, LSS
// Fastscan / Slowscan / switch selective), commissions them (node-IDs from
// the configuration by serial, the swap policy, or the pool; stored in the
// device and in the state file), configures them (SDO plan with read-back,
// store on change, NMT start), supervises them (heartbeat consumer or node
// guarding, boot-up -> reconfigure, EMCY, bus events, interface loss ->
// reopen with backoff) and produces SYNC when configured.
//
// Threads: start() spawns the bus's control thread, which owns the control
// socket and every protocol component; stop() ends and joins it within 1 s.
// status(), ready(), request_commission(), reload(), submit() and
// submit_service() may be called from any thread (they take a mutex; never on the hot path). Observer callbacks run on
// the control thread and must not block.
#pragma once

#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "bus/bus_clock.hpp"
#include "bus/bus_health.hpp"
#include "bus/device_command.hpp"
#include "bus/device_status.hpp"
#include "bus/service/service_request.hpp"
#include "bus/service/service_replies.hpp"
#include "bus/state_store.hpp"
#include "can/bus_port.hpp"

#include <memory>
#include <system_error>
#include <vector>

namespace cobridge::bus {

// Told about devices as they are configured and change state, so the hot
// path can decode their PDOs and the plugins can publish status.
// A gateway's role on one bus of a hot-standby pair, as the outputs see it.
struct BusRole {
  enum class Kind : std::uint8_t { undecided, master, standby };
  Kind kind = Kind::undecided;
  std::uint8_t own_node = 0;
  std::uint8_t master_node = 0;  // 0 = none known
  std::uint8_t peer_node = 0;    // the other gateway heard on the bus, 0 = none yet
  std::string cause;
  std::uint64_t since_ns = 0;  // realtime
};

class BusObserver {
 public:
  virtual ~BusObserver() = default;
  // The device at `node_id` now sends TPDOs with these mapping entries
  // (0x1A00/0x1A01 as read back, 0xIIIISSLL form); empty = PDO disabled.
  virtual void on_device_configured(const DeviceStatus& device, const std::vector<std::uint32_t>& tpdo1_mapping,
                                    const std::vector<std::uint32_t>& tpdo2_mapping) = 0;
  virtual void on_device_status(const DeviceStatus& device) = 0;
  // A command given to submit() has finished (or was refused on the control
  // thread). Called exactly once per accepted command.
  virtual void on_command_done(const DeviceStatus& /*device*/, const DeviceCommand& /*command*/,
                               const CommandOutcome& /*outcome*/) {}
  // A device the gateway forgot (an unknown device that turned out to be a
  // configured one's replacement, or left the configuration on a reload):
  // its index and node-ID are free again.
  virtual void on_device_removed(const DeviceStatus& /*device*/) {}
  // Hot standby ([redundancy]): the gateway's role on this bus changed.
  virtual void on_role_changed(const BusRole& /*role*/) {}
  // The bus's health changed (interface open, CAN controller state and
  // counters): a transition at once, counters at most once a second
  // (BusHealthGate); once at start.
  virtual void on_bus_health(const BusHealth& /*health*/) {}
};

class BusRegistry;
class CaptureWriter;

struct BusManagerOptions {
  // How long start-up waits for the known devices before ready() is true anyway.
  std::chrono::milliseconds ready_timeout{10000};
  BusObserver* observer = nullptr;
  // Where clients' commands (control socket, CiA 309-3) find this bus while
  // it runs; the daemon makes one and passes it to every bus and to the
  // control socket. nullptr: the bus takes no client commands.
  BusRegistry* registry = nullptr;
  // The bus's flight recorder captures: the control thread requests one
  // around each fault it sees. nullptr: recorder off.
  CaptureWriter* captures = nullptr;
  // Unit tests: the bus to run on instead of a SocketCAN socket on the
  // configured interface (can::VirtualBus::Port; the caller owns it), and
  // the clock to read instead of the system's. With them, open() and
  // turn() drive the bus without a thread, on the test's time.
  can::BusPort* port = nullptr;
  const BusClock* clock = nullptr;
};

class BusManager {
 public:
  BusManager(const config::Config& config, std::size_t bus_index, const device::DeviceCatalog& catalog,
             StateStore& state, BusManagerOptions options = {});
  ~BusManager();
  BusManager(const BusManager&) = delete;
  BusManager& operator=(const BusManager&) = delete;

  // Opens the bus and starts the control thread. A failure is returned, not
  // logged: its where names the bus and the interface.
  Error start();
  void stop();

  // Stepped use, without a thread (unit tests, options.port and .clock):
  // open() instead of start(); then turn(now) whenever a frame came or the
  // deadline it returned has passed: one turn of the control loop, frames
  // read from the port, components run; close() ends it (as stop() does).
  // The calls of other threads below work the same, the test being every
  // thread. Never mixed with start().
  Error open();
  [[nodiscard]] canopen::TimePoint turn(canopen::TimePoint now);
  void close();

  // True once every configured device is operational or has timed out
  // (ready_timeout), so the daemon can tell systemd READY=1.
  [[nodiscard]] bool ready() const;
  // True while the control thread runs and the interface is open (watchdog).
  [[nodiscard]] bool serving() const;
  [[nodiscard]] BusStatus status() const;

  // `cobridge commission`: resolve clashes / assign now, whatever the policy.
  void request_commission();
  // `cobridge acknowledge DEVICE`: the device's contested objects
  // (bus/restore_guard.hpp) may be written again; `caller` goes on its
  // timeline. Queued for the control thread; a device without contested
  // objects is left as it is. Never blocks.
  void acknowledge_contested(std::string device, std::string caller);
  // SIGHUP: new device settings without closing the bus.
  void reload(const config::Config& config);

  // A plugin's command (preset, NMT reset, store) for one configured device.
  // Queued for the control thread, which runs it when the device is
  // operational and not being configured, and reports the outcome through
  // BusObserver::on_command_done. Returns ok when queued, busy when the
  // queue is full (then no outcome follows). Never blocks.
  [[nodiscard]] CommandStatus submit(DeviceCommand command);

  // A client's SDO / NMT / LSS command (control socket, CiA 309-3 gateway),
  // run by the control thread's ServiceExecutor between its own
  // work; the result goes to `reply_to`. Error kUnavailable when the queue
  // is full or the bus does not run (then no result follows). Never blocks.
  [[nodiscard]] Error submit_service(ServiceRequest command, std::shared_ptr<ServiceReplies> reply_to);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cobridge::bus
