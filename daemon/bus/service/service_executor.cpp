#include "bus/service/service_executor.hpp"

#include "base/number_text.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/sdo_abort.hpp"
#include "sys/logging.hpp"

#include <algorithm>
#include <cstdio>

namespace cobridge::bus {
namespace {

using canopen::kNever;
using canopen::TimePoint;
using std::chrono::milliseconds;

// A transfer the device lost is started again this long after (its boot-up,
// its silence): the node is then usually seen busy (being configured).
constexpr milliseconds kRestartDelay{100};
// Protocol aborts (not silence) repeated at most this often per command.
constexpr unsigned kProtocolRestarts = 3;
// How often a command waiting for a busy node looks again (the bus manager's
// own events also make the loop turn).
constexpr milliseconds kWaitPoll{20};

std::string where_of(const std::string& bus, std::uint8_t node) {
  return "bus '" + bus + "' node " + std::to_string(node);
}

bool is_boot_up(const can::Frame& f, std::uint8_t node) {
  return f.id == canopen::cob::kNmtErrorControlBase + node && f.len == 1 && f.data[0] == 0 && !f.is_rtr();
}

}  // namespace

ServiceExecutor::ServiceExecutor(can::FrameSink& sink, std::string bus_name, canopen::Duration lss_timeout)
    : sink_(sink), bus_(std::move(bus_name)), lss_(sink, canopen::LssMaster::Config{.timeout = lss_timeout}) {}

ServiceExecutor::~ServiceExecutor() { abort_all("the bus stopped"); }

void ServiceExecutor::add(ServiceRequest command, std::shared_ptr<ServiceReplies> reply_to, TimePoint now) {
  Entry e;
  e.deadline = now + command.deadline;
  e.not_before = now;
  e.cmd = std::move(command);
  e.to = std::move(reply_to);
  queue_.push_back(std::move(e));
}

std::uint8_t ServiceExecutor::sdo_node() const noexcept {
  if (!active_ || (active_->cmd.op != ServiceOp::sdo_upload && active_->cmd.op != ServiceOp::sdo_download)) return 0;
  return active_->cmd.node;
}

bool ServiceExecutor::lss_session(TimePoint now) const noexcept {
  return (active_ && active_->cmd.op == ServiceOp::lss) || now < lss_session_until_;
}

void ServiceExecutor::on_frame(const can::Frame& frame, TimePoint now) {
  if (!active_) return;
  if (active_->cmd.op == ServiceOp::lss) {
    if (frame.id == canopen::cob::kLssSlaveToMaster)
      sys::logger("gateway")->debug("bus {}: LSS answer {:02X} for a client", bus_, frame.data[0]);
    lss_.on_frame(frame, now);
    return;
  }
  if (!sdo_) return;
  if (is_boot_up(frame, active_->cmd.node)) {
    // The device restarted: the transfer is gone with it (CiA 301 §7.2.4.3:
    // a server knows no transfer after a reset). Not an error of the client.
    sdo_->forget();
    retry_later(now, "the device rebooted");
    return;
  }
  sdo_->on_frame(frame, now);
}

TimePoint ServiceExecutor::process(TimePoint now, ServiceGate& gate) {
  TimePoint next = kNever;
  if (active_) next = std::min(next, drive(now, gate));
  expire(now);
  for (auto it = queue_.begin(); !active_ && it != queue_.end(); ++it) {
    if (!startable(*it, now, gate)) continue;
    Entry e = std::move(*it);
    queue_.erase(it);
    start(std::move(e), now, gate);
    if (active_) next = std::min(next, drive(now, gate));
    break;
  }
  if (!queue_.empty()) next = std::min(next, now + kWaitPoll);
  return next;
}

bool ServiceExecutor::startable(const Entry& e, TimePoint now, ServiceGate& gate) const {
  if (now < e.not_before) return false;
  if (e.cmd.op == ServiceOp::lss) return gate.lss_allowed();
  return gate.node_free(e.cmd.node);
}

void ServiceExecutor::expire(TimePoint now) {
  for (auto it = queue_.begin(); it != queue_.end();) {
    if (now < it->deadline) {
      ++it;
      continue;
    }
    ServiceResult r;
    r.error = Error(Errc::kTimeout,
                    "not run within " + std::to_string(it->cmd.deadline.count()) +
                        " ms: the node stayed busy (being configured, rebooting or offline)" +
                        (it->restarts != 0 ? " after " + std::to_string(it->restarts) + " lost transfer(s)" : ""),
                    where_of(bus_, it->cmd.node));
    reply(*it, std::move(r));
    it = queue_.erase(it);
  }
}

void ServiceExecutor::start(Entry e, TimePoint now, ServiceGate& gate) {
  active_ = std::move(e);
  switch (active_->cmd.op) {
    case ServiceOp::sdo_upload:
    case ServiceOp::sdo_download:
      start_sdo(now);
      return;
    case ServiceOp::nmt: {
      ServiceResult r;
      if (!sink_.send(canopen::make_nmt(active_->cmd.nmt, active_->cmd.node))) {
        r.error = Error(Errc::kUnavailable, "the NMT frame could not be sent", where_of(bus_, active_->cmd.node));
      } else {
        gate.on_nmt_sent(active_->cmd.nmt, active_->cmd.node, active_->cmd.caller);
      }
      reply(*active_, std::move(r));
      active_.reset();
      return;
    }
    case ServiceOp::lss:
      lss_step_ = 0;
      lss_value_ = 0;
      lss_values_.clear();
      start_lss_step(now, gate);
      return;
  }
}

void ServiceExecutor::start_sdo(TimePoint now) {
  auto& c = active_->cmd;
  canopen::SdoClientConfig sc;
  sc.timeout = c.sdo_timeout;
  sc.buffer_size = std::max<std::size_t>(1024, c.data.size());
  sdo_ = std::make_unique<canopen::SdoClient>(sink_, c.node, sc);
  const std::error_code ec = c.op == ServiceOp::sdo_upload ? sdo_->start_upload(c.index, c.sub, now)
                                                          : sdo_->start_download(c.index, c.sub, c.data, now);
  if (!ec) return;
  if (ec == std::errc::no_buffer_space) {
    retry_later(now, "the CAN transmit queue is full");
    return;
  }
  ServiceResult r;
  r.error = Error(Errc::kInvalidArgument, ec.message(), where_of(bus_, c.node), ec);
  reply(*active_, std::move(r));
  active_.reset();
}

TimePoint ServiceExecutor::drive(TimePoint now, ServiceGate& gate) {
  if (active_->cmd.op == ServiceOp::lss) {
    const TimePoint next = lss_.process(now);
    if (auto r = lss_.take_result()) lss_step_done(r->error, r->value, now, gate);
    return active_ ? next : kNever;
  }
  const TimePoint next = sdo_->process(now);
  // Done: process() starts the next command in the same turn, so no
  // deadline is owed (an extra loop turn would delay the answer).
  if (auto r = sdo_->take_result()) {
    finish_sdo(*r, now, gate);
    return kNever;
  }
  return next;
}

void ServiceExecutor::finish_sdo(const canopen::SdoClient::Result& r, TimePoint now, ServiceGate& gate) {
  auto& c = active_->cmd;
  const bool silence = r.error == canopen::make_error_code(canopen::SdoAbort::kProtocolTimedOut);
  if (silence && gate.node_supervised(c.node) && now + c.sdo_timeout < active_->deadline) {
    // Silence may be a power cycle: ask again once the node is back.
    retry_later(now, "no answer");
    return;
  }
  // A protocol abort (CiA 301 §7.2.4.3.17: 0x0503xxxx toggle, 0x0504xxxx
  // command specifier / timeout) says the two ends lost step (a late segment
  // of a transfer that timed out, a reset we did not see yet), not that the
  // object cannot be read: the transfer is made again, a few times.
  const auto wire = canopen::sdo_abort_wire_code(r.error);
  const bool protocol = (wire & 0xFFFF0000U) == 0x05030000U || (wire & 0xFFFF0000U) == 0x05040000U;
  if (!silence && protocol && active_->restarts < kProtocolRestarts && now + c.sdo_timeout < active_->deadline) {
    retry_later(now, "protocol abort");
    return;
  }
  ServiceResult out;
  const std::string where = where_of(bus_, c.node) + " object " + object_text(c.index, c.sub);
  if (r.ok()) {
    out.data.assign(r.data.begin(), r.data.end());
    if (c.op == ServiceOp::sdo_download) gate.on_sdo_written(c, now);
  } else if (silence) {
    out.error = Error(Errc::kTimeout, "no answer from the device", where, r.error);
  } else {
    out.abort_code = canopen::sdo_abort_wire_code(r.error);
    out.error = Error(Errc::kFailed, r.error.message(), where, r.error);
  }
  reply(*active_, std::move(out));
  active_.reset();
  sdo_.reset();
}

void ServiceExecutor::retry_later(TimePoint now, const char* why) {
  Entry e = std::move(*active_);
  active_.reset();
  sdo_.reset();
  ++e.restarts;
  e.not_before = now + kRestartDelay;
  sys::logger("gateway")->debug("bus {}: client {} on node {}: {}; again when the node is free", bus_,
                                to_string(e.cmd.op), e.cmd.node, why);
  queue_.push_front(std::move(e));
}

void ServiceExecutor::reply(Entry& e, ServiceResult result) {
  result.tag = e.cmd.tag;
  if (e.to) e.to->push(std::move(result));
  e.to.reset();
}

void ServiceExecutor::abort_all(const std::string& why) {
  if (active_) {
    lss_.cancel();
    if (sdo_) sdo_->forget();
    ServiceResult r;
    r.error = Error(Errc::kUnavailable, why, "bus '" + bus_ + "'");
    reply(*active_, std::move(r));
    active_.reset();
  }
  for (auto& e : queue_) {
    ServiceResult r;
    r.error = Error(Errc::kUnavailable, why, "bus '" + bus_ + "'");
    reply(e, std::move(r));
  }
  queue_.clear();
}

}  // namespace cobridge::bus
