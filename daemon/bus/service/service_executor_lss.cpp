// ServiceExecutor, the LSS part: a command's steps one after the other on the
// daemon's LSS master (CiA 305), the session they open, and what the bus
// manager learns (ServiceGate::on_lss_node_id).
#include "bus/service/service_executor.hpp"

#include "sys/logging.hpp"

namespace cobridge::bus {
namespace {

using canopen::TimePoint;
constexpr std::chrono::milliseconds kLssSessionHold{10000};

canopen::LssCs inquiry(LssStep::Kind k) {
  switch (k) {
    case LssStep::Kind::inquire_vendor: return canopen::LssCs::kInquireVendor;
    case LssStep::Kind::inquire_product: return canopen::LssCs::kInquireProduct;
    case LssStep::Kind::inquire_revision: return canopen::LssCs::kInquireRevision;
    case LssStep::Kind::inquire_serial: return canopen::LssCs::kInquireSerial;
    default: return canopen::LssCs::kInquireNodeId;
  }
}

}  // namespace

void ServiceExecutor::start_lss_step(TimePoint now, ServiceGate& gate) {
  const auto& steps = active_->cmd.lss_steps;
  if (lss_step_ >= steps.size()) {
    ServiceResult r;
    r.value = lss_value_;
    r.values = std::move(lss_values_);
    reply(*active_, std::move(r));
    active_.reset();
    return;
  }
  const LssStep& s = steps[lss_step_];
  // Discovery waits while devices may be in configuration state: after a
  // step that can put them there, or any step of a session still held. An
  // inquiry outside a session (nobody may be listening) holds nothing
  // unless a device answers it (lss_step_done).
  const bool opens =
      (s.kind == LssStep::Kind::switch_global && s.value != 0) || s.kind == LssStep::Kind::switch_selective;
  if (opens || now < lss_session_until_) lss_session_until_ = now + kLssSessionHold;
  std::error_code ec;
  switch (s.kind) {
    case LssStep::Kind::switch_global: {
      const auto mode = s.value == 0 ? canopen::LssMode::kWaiting : canopen::LssMode::kConfiguration;
      ec = lss_.switch_state_global(mode);
      if (mode == canopen::LssMode::kWaiting) {
        lss_session_until_ = {};
        selected_.reset();
      }
      // No answer to wait for (CiA 305): the step is done.
      lss_step_done(ec, 0, now, gate);
      return;
    }
    case LssStep::Kind::switch_selective:
      selected_ = s.address;
      ec = lss_.switch_state_selective(s.address, now);
      break;
    case LssStep::Kind::set_node_id:
      ec = lss_.configure_node_id(static_cast<std::uint8_t>(s.value), now);
      break;
    case LssStep::Kind::store:
      ec = lss_.store_configuration(now);
      break;
    default:
      ec = lss_.inquire(inquiry(s.kind), now);
      break;
  }
  sys::logger("gateway")->debug("bus {}: client LSS step {} started: {}", bus_, lss_step_, ec ? ec.message() : "ok");
  if (ec) lss_step_done(ec, 0, now, gate);
}

void ServiceExecutor::lss_step_done(std::error_code ec, std::uint32_t value, TimePoint now, ServiceGate& gate) {
  const auto& steps = active_->cmd.lss_steps;
  const LssStep& s = steps[lss_step_];
  if (ec) {
    ServiceResult r;
    const bool silent = ec == canopen::make_error_code(canopen::LssErrc::kTimeout);
    r.error = Error(silent ? Errc::kTimeout : Errc::kFailed, ec.message(), "bus '" + bus_ + "' LSS step " +
                                                                               std::to_string(lss_step_ + 1), ec);
    if (s.kind == LssStep::Kind::switch_selective) selected_.reset();
    // A command that was to end in waiting state ends there also after a failure.
    if (!steps.empty() && steps.back().kind == LssStep::Kind::switch_global && steps.back().value == 0 &&
        lss_step_ + 1 < steps.size()) {
      (void)lss_.switch_state_global(canopen::LssMode::kWaiting);
      lss_session_until_ = {};
      selected_.reset();
    }
    reply(*active_, std::move(r));
    active_.reset();
    return;
  }
  // A device answered (CiA 305: only one in configuration state does).
  if (s.kind != LssStep::Kind::switch_global) lss_session_until_ = now + kLssSessionHold;
  if (s.kind >= LssStep::Kind::inquire_vendor) {
    lss_value_ = value;
    lss_values_.push_back(value);
  }
  if (s.kind == LssStep::Kind::set_node_id && selected_) {
    const bool store_follows = lss_step_ + 1 < steps.size() && steps[lss_step_ + 1].kind == LssStep::Kind::store;
    if (!store_follows) gate.on_lss_node_id(*selected_, static_cast<std::uint8_t>(s.value), false);
  }
  if (s.kind == LssStep::Kind::store && selected_ && lss_step_ > 0 &&
      steps[lss_step_ - 1].kind == LssStep::Kind::set_node_id) {
    gate.on_lss_node_id(*selected_, static_cast<std::uint8_t>(steps[lss_step_ - 1].value), true);
  }
  ++lss_step_;
  start_lss_step(now, gate);
}

}  // namespace cobridge::bus
