// ServiceExecutor: runs the ServiceRequests of one bus (CLI through the
// control socket, CiA 309-3 clients) with the daemon's own protocol
// services, queued with the bus manager's work.
//
// The rules that keep the daemon the one master of its bus:
//   * one client SDO transfer at a time per bus, and only on a node the bus
//     manager says is free (ServiceGate::node_free: no configuration,
//     identity read or plugin command runs on it, it is not on its way back
//     from a reboot); while it runs the bus manager starts none of its own
//     on that node (sdo_node());
//   * a transfer the device loses (boot-up seen mid-transfer, or no answer
//     within the SDO timeout: the device may be power-cycling) is started
//     again once the node is free, until the command's deadline: a read may
//     wait for a reboot, it never fails with the abort the reboot caused;
//   * commands wait in order, but one waiting for a busy node does not hold
//     up one for another node;
//   * LSS runs only when the gate allows it (no commissioning under way),
//     and discovery waits while an LSS command runs and while devices may
//     still be in LSS configuration state (lss_session(): 10 s after a
//     step that can switch them there, a step of a session still held, or
//     a device's answer; not after an inquiry nobody answered outside one);
//   * NMT and LSS results and confirmed SDO downloads go to the gate, so
//     the bus manager knows what a client did (a device stopped on purpose,
//     a node-ID set, a configured object written).
//
// Thread: the bus's control thread owns it, like every protocol component:
// frames and `now` are passed in, process(now, gate) returns the next
// deadline. Results are pushed to each command's ServiceReplies, tagged;
// the thread that owns the client's connection writes the answer (nothing
// here touches a client's socket).
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss_master.hpp"
#include "canopen/sdo_client.hpp"
#include "bus/service/service_request.hpp"
#include "bus/service/service_replies.hpp"

#include <deque>
#include <memory>
#include <optional>
#include <string>

namespace cobridge::bus {

// What the bus manager tells the executor, and learns from it.
class ServiceGate {
 public:
  virtual ~ServiceGate() = default;
  // Node 1..127: a client transfer / NMT command may address it now.
  // Node 0: the whole bus (NMT to all nodes).
  [[nodiscard]] virtual bool node_free(std::uint8_t node) const = 0;
  // A configured device is at this node: silence from it may be a power
  // cycle, worth waiting for; silence from any other node is a timeout.
  [[nodiscard]] virtual bool node_supervised(std::uint8_t node) const = 0;
  // No commissioning under way: LSS may run.
  [[nodiscard]] virtual bool lss_allowed() const = 0;
  virtual void on_nmt_sent(canopen::NmtCommand command, std::uint8_t node, const std::string& caller) = 0;
  // A node-ID was configured (and stored) in the device of that identity.
  virtual void on_lss_node_id(const canopen::LssAddress& device, std::uint8_t node, bool stored) = 0;
  // A client's SDO download the device confirmed (CiA 301 §7.2.4.3.3/5):
  // the bus manager compares it with the device's configuration
  // (bus/config_drift.hpp). Called before the client's answer is pushed.
  virtual void on_sdo_written(const ServiceRequest& command, canopen::TimePoint now) = 0;
};

class ServiceExecutor {
 public:
  ServiceExecutor(can::FrameSink& sink, std::string bus_name, canopen::Duration lss_timeout);
  ~ServiceExecutor();
  ServiceExecutor(const ServiceExecutor&) = delete;
  ServiceExecutor& operator=(const ServiceExecutor&) = delete;

  void add(ServiceRequest command, std::shared_ptr<ServiceReplies> reply_to, canopen::TimePoint now);
  void on_frame(const can::Frame& frame, canopen::TimePoint now);
  canopen::TimePoint process(canopen::TimePoint now, ServiceGate& gate);

  // The node of the running client SDO transfer; 0 when none.
  [[nodiscard]] std::uint8_t sdo_node() const noexcept;
  // True while an LSS command runs or devices may be in LSS configuration
  // state: discovery must not send (or be fed) LSS frames.
  [[nodiscard]] bool lss_session(canopen::TimePoint now) const noexcept;
  [[nodiscard]] std::size_t waiting() const noexcept { return queue_.size() + (active_ ? 1U : 0U); }
  // Every command ends with `why` (the bus stops).
  void abort_all(const std::string& why);

 private:
  struct Entry {
    ServiceRequest cmd;
    std::shared_ptr<ServiceReplies> to;
    canopen::TimePoint deadline{};
    canopen::TimePoint not_before{};
    unsigned restarts = 0;  // transfers started again after a reboot / silence
  };

  bool startable(const Entry& e, canopen::TimePoint now, ServiceGate& gate) const;
  void start(Entry e, canopen::TimePoint now, ServiceGate& gate);
  void start_sdo(canopen::TimePoint now);
  void start_lss_step(canopen::TimePoint now, ServiceGate& gate);
  canopen::TimePoint drive(canopen::TimePoint now, ServiceGate& gate);
  void finish_sdo(const canopen::SdoClient::Result& r, canopen::TimePoint now, ServiceGate& gate);
  void lss_step_done(std::error_code ec, std::uint32_t value, canopen::TimePoint now, ServiceGate& gate);
  void retry_later(canopen::TimePoint now, const char* why);
  void reply(Entry& e, ServiceResult result);
  void expire(canopen::TimePoint now);

  can::FrameSink& sink_;
  std::string bus_;
  canopen::LssMaster lss_;
  std::unique_ptr<canopen::SdoClient> sdo_;
  std::deque<Entry> queue_;
  std::optional<Entry> active_;
  std::size_t lss_step_ = 0;
  std::uint32_t lss_value_ = 0;
  std::vector<std::uint32_t> lss_values_;
  std::optional<canopen::LssAddress> selected_;  // the device switched selectively
  canopen::TimePoint lss_session_until_{};
};

}  // namespace cobridge::bus
