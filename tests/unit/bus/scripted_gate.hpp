// The ServiceExecutor tests' bus: a CAN sink that records what is sent, and
// a ServiceGate the test scripts (busy and supervised nodes; NMT commands
// recorded). Test thread only.
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "bus/service/service_executor.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace cobridge::bus::testing {

struct RecordingSink : can::FrameSink {
  bool send(const can::Frame& f) noexcept override {
    sent.push_back(f);
    return true;
  }
  std::vector<can::Frame> sent;
};

struct ScriptedGate : ServiceGate {
  bool node_free(std::uint8_t node) const override { return busy.count(node) == 0; }
  bool node_supervised(std::uint8_t node) const override { return supervised.count(node) != 0; }
  bool lss_allowed() const override { return true; }
  void on_nmt_sent(canopen::NmtCommand, std::uint8_t node, const std::string&) override { nmt.push_back(node); }
  void on_lss_node_id(const canopen::LssAddress&, std::uint8_t, bool) override {}
  void on_sdo_written(const ServiceRequest& c, canopen::TimePoint) override { written.push_back(c); }
  std::set<std::uint8_t> busy, supervised;
  std::vector<std::uint8_t> nmt;
  std::vector<ServiceRequest> written;  // confirmed downloads
};

// One bus "line1" as its control thread sees it: the executor under test,
// its sink and gate, a reply queue, a start time.
struct ServiceBus {
  // CiA 301 §7.2.4.3.6: an expedited upload of 0x1018:4 (serial) from `node`, tag 7.
  static ServiceRequest upload(std::uint8_t node) {
    ServiceRequest c;
    c.op = ServiceOp::sdo_upload;
    c.node = node;
    c.index = 0x1018;
    c.sub = 4;
    c.sdo_timeout = std::chrono::milliseconds(100);
    c.deadline = std::chrono::milliseconds(2000);
    c.tag = 7;
    return c;
  }

  RecordingSink bus;
  ScriptedGate gate;
  ServiceExecutor ex{bus, "line1", std::chrono::milliseconds(100)};
  std::shared_ptr<ServiceReplies> replies = std::make_shared<ServiceReplies>();
  canopen::TimePoint t0 = canopen::TimePoint{} + std::chrono::hours(1);
};

}  // namespace cobridge::bus::testing
