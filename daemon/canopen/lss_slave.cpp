#include "canopen/lss_slave.hpp"

namespace cobridge::canopen {

namespace {

constexpr uint8_t kFastscanLastField = kLssFieldCount - 1;

}  // namespace

LssSlave::LssSlave(can::FrameSink& sink, const LssAddress& identity, uint8_t active_node_id,
                   Features features) noexcept
    : sink_(sink),
      identity_(identity),
      features_(features),
      active_node_id_(active_node_id),
      pending_node_id_(active_node_id) {}

bool LssSlave::unconfigured() const noexcept {
  return active_node_id_ == cob::kNodeIdUnconfigured && pending_node_id_ == cob::kNodeIdUnconfigured;
}

void LssSlave::activate_pending() noexcept {
  active_node_id_ = pending_node_id_;
  active_bit_timing_ = pending_bit_timing_;
  mode_ = LssMode::kWaiting;
  selective_next_ = 0;
  identify_next_ = 0;
  fastscan_sub_ = 0;
  reset_requested_ = false;
}

std::optional<uint16_t> LssSlave::take_bit_timing_activation() noexcept {
  const auto delay = activation_delay_ms_;
  activation_delay_ms_.reset();
  return delay;
}

bool LssSlave::take_reset_communication_request() noexcept {
  const bool requested = reset_requested_;
  reset_requested_ = false;
  return requested;
}

void LssSlave::reply(LssCs cs, uint32_t value) noexcept {
  if (!sink_.send(lss_frame(cob::kLssSlaveToMaster, static_cast<uint8_t>(cs), value))) ++tx_failures_;
}

void LssSlave::reply_error(LssCs cs, uint8_t error) noexcept { reply(cs, error); }

bool LssSlave::on_frame(const can::Frame& f) noexcept {
  if (ignore_ || !is_lss_frame(f, cob::kLssMasterToSlave)) return false;
  const auto cs = static_cast<LssCs>(f.data[0]);
  const bool configuring = mode_ == LssMode::kConfiguration;
  switch (cs) {
    case LssCs::kSwitchStateGlobal:
      on_switch_global(f);
      return true;
    case LssCs::kSwitchSelectiveVendor:
    case LssCs::kSwitchSelectiveProduct:
    case LssCs::kSwitchSelectiveRevision:
    case LssCs::kSwitchSelectiveSerial:
      return on_switch_selective(cs, lss_value(f));
    case LssCs::kConfigureNodeId:
      return configuring && on_configure_node_id(f);
    case LssCs::kConfigureBitTiming:
      return configuring && on_bit_timing(f);
    case LssCs::kActivateBitTiming:
      return configuring && on_activate_bit_timing(f);
    case LssCs::kStoreConfiguration:
      return configuring && on_store();
    case LssCs::kIdentifyVendor:
    case LssCs::kIdentifyProduct:
    case LssCs::kIdentifyRevisionLow:
    case LssCs::kIdentifyRevisionHigh:
    case LssCs::kIdentifySerialLow:
    case LssCs::kIdentifySerialHigh:
      return on_identify(cs, lss_value(f));
    case LssCs::kIdentifyNonConfigured:
      if (!features_.identify || configuring || !unconfigured()) return false;
      reply(LssCs::kIdentifyNonConfiguredSlave);
      return true;
    case LssCs::kFastscan:
      return on_fastscan(f);
    case LssCs::kInquireVendor:
    case LssCs::kInquireProduct:
    case LssCs::kInquireRevision:
    case LssCs::kInquireSerial:
    case LssCs::kInquireNodeId:
      return on_inquire(cs);
    case LssCs::kSwitchSelectiveResponse:
    case LssCs::kIdentifySlave:
    case LssCs::kIdentifyNonConfiguredSlave:
      break;  // answers, never requests
  }
  return false;
}

bool LssSlave::on_configure_node_id(const can::Frame& f) noexcept {
  const auto cs = LssCs::kConfigureNodeId;
  const uint8_t id = f.data[1];
  if (node_id_requests_lost_ < features_.lose_node_id_requests) {
    ++node_id_requests_lost_;
    return true;
  }
  if (features_.node_id_assignment == LssSlaveFeatures::NodeIdAssignment::ignore) return true;
  if (!lss_node_id_acceptable(id) || features_.node_id_assignment == LssSlaveFeatures::NodeIdAssignment::refuse) {
    reply_error(cs, static_cast<uint8_t>(LssNodeIdError::kOutOfRange));
    return true;
  }
  pending_node_id_ = id;
  reply_error(cs, static_cast<uint8_t>(LssNodeIdError::kOk));
  return true;
}

// CiA 305 makes this a broadcast every configured slave obeys at once; the
// delay lets the owner switch after the bus has gone quiet.
bool LssSlave::on_activate_bit_timing(const can::Frame& f) noexcept {
  if (!features_.bit_timing) return false;
  active_bit_timing_ = pending_bit_timing_;
  activation_delay_ms_ = static_cast<uint16_t>(f.data[1] | (f.data[2] << 8));
  return true;
}

void LssSlave::on_switch_global(const can::Frame& f) noexcept {
  const uint8_t m = f.data[1];
  if (m > static_cast<uint8_t>(LssMode::kConfiguration)) return;
  const auto next = static_cast<LssMode>(m);
  if (mode_ == LssMode::kConfiguration && next == LssMode::kWaiting &&
      active_node_id_ == cob::kNodeIdUnconfigured && cob::valid_node_id(pending_node_id_)) {
    reset_requested_ = true;
  }
  mode_ = next;
  selective_next_ = 0;
  identify_next_ = 0;
}

bool LssSlave::on_switch_selective(LssCs cs, uint32_t value) noexcept {
  if (mode_ != LssMode::kWaiting) return false;
  const auto step = static_cast<uint8_t>(static_cast<uint8_t>(cs) -
                                         static_cast<uint8_t>(LssCs::kSwitchSelectiveVendor));
  // A vendor frame always restarts the sequence; any other frame must follow
  // its predecessor, or the sequence is abandoned until the next vendor frame.
  if (step != 0 && step != selective_next_) {
    selective_next_ = 0;
    return true;
  }
  if (value != identity_.field(static_cast<LssField>(step))) {
    selective_next_ = 0;
    return true;
  }
  if (step < kFastscanLastField) {
    selective_next_ = static_cast<uint8_t>(step + 1);
    return true;
  }
  selective_next_ = 0;
  mode_ = LssMode::kConfiguration;
  reply(LssCs::kSwitchSelectiveResponse);
  return true;
}

bool LssSlave::on_identify(LssCs cs, uint32_t value) noexcept {
  if (!features_.identify || mode_ != LssMode::kWaiting) return false;
  const auto step = static_cast<uint8_t>(static_cast<uint8_t>(cs) -
                                         static_cast<uint8_t>(LssCs::kIdentifyVendor));
  if (step != 0 && step != identify_next_) {
    identify_next_ = 0;
    return true;
  }
  bool match = false;
  switch (cs) {
    case LssCs::kIdentifyVendor: match = identity_.vendor == value; break;
    case LssCs::kIdentifyProduct: match = identity_.product == value; break;
    case LssCs::kIdentifyRevisionLow: match = identity_.revision >= value; break;
    case LssCs::kIdentifyRevisionHigh: match = identity_.revision <= value; break;
    case LssCs::kIdentifySerialLow: match = identity_.serial >= value; break;
    case LssCs::kIdentifySerialHigh: match = identity_.serial <= value; break;
    default: break;
  }
  if (!match) {
    identify_next_ = 0;
    return true;
  }
  if (cs != LssCs::kIdentifySerialHigh) {
    identify_next_ = static_cast<uint8_t>(step + 1);
    return true;
  }
  identify_next_ = 0;
  reply(LssCs::kIdentifySlave);
  return true;
}

bool LssSlave::on_fastscan(const can::Frame& f) noexcept {
  if (!features_.fastscan || mode_ != LssMode::kWaiting || !unconfigured()) return false;
  const uint32_t id_number = lss_value(f);
  const uint8_t bit_checked = f.data[5];
  const uint8_t sub = f.data[6];
  const uint8_t next = f.data[7];
  if (bit_checked == kLssFastscanReset) {
    fastscan_sub_ = 0;
    reply(LssCs::kIdentifySlave);
    return true;
  }
  if (bit_checked > 31 || sub > kFastscanLastField || next > kFastscanLastField) return true;
  // A slave that fell behind on an earlier field stays out of this round.
  if (sub != fastscan_sub_) return true;
  const uint32_t mask = 0xFFFFFFFFu << bit_checked;
  if ((identity_.field(static_cast<LssField>(sub)) & mask) != (id_number & mask)) return true;
  reply(LssCs::kIdentifySlave);
  if (bit_checked == 0) {
    // The master confirms a complete field by naming the next one; naming a
    // field before the current one means the whole address matched.
    if (next < sub) {
      mode_ = LssMode::kConfiguration;
      fastscan_sub_ = 0;
    } else {
      fastscan_sub_ = next;
    }
  }
  return true;
}

bool LssSlave::on_bit_timing(const can::Frame& f) noexcept {
  const auto not_supported = static_cast<uint8_t>(LssBitTimingError::kNotSupported);
  if (!features_.bit_timing) {
    reply_error(LssCs::kConfigureBitTiming, not_supported);
    return true;
  }
  const auto supported = [this](unsigned index) {
    return index < 16 && (features_.bit_timings & (1u << index)) != 0;
  };
  uint8_t selector = f.data[1];
  uint8_t index = f.data[2];
  if (features_.accept_j_bit_timing_form && selector != kLssBitTimingTableStandard && index == 0 &&
      supported(selector)) {
    index = selector;
    selector = kLssBitTimingTableStandard;
  }
  if (selector != kLssBitTimingTableStandard || !supported(index)) {
    reply_error(LssCs::kConfigureBitTiming, not_supported);
    return true;
  }
  pending_bit_timing_ = index;
  reply_error(LssCs::kConfigureBitTiming, static_cast<uint8_t>(LssBitTimingError::kOk));
  return true;
}

bool LssSlave::on_store() noexcept {
  if (!features_.store) {
    reply_error(LssCs::kStoreConfiguration, static_cast<uint8_t>(LssStoreError::kNotSupported));
    return true;
  }
  const LssStoreError err = store_handler_ ? store_handler_(*this) : LssStoreError::kOk;
  if (err == LssStoreError::kOk) {
    stored_node_id_ = pending_node_id_;
    stored_bit_timing_ = pending_bit_timing_;
  }
  reply_error(LssCs::kStoreConfiguration, static_cast<uint8_t>(err));
  return true;
}

bool LssSlave::on_inquire(LssCs cs) noexcept {
  if (!features_.inquire || mode_ != LssMode::kConfiguration) return false;
  uint32_t value = 0;
  switch (cs) {
    case LssCs::kInquireVendor: value = identity_.vendor; break;
    case LssCs::kInquireProduct: value = identity_.product; break;
    case LssCs::kInquireRevision: value = identity_.revision; break;
    case LssCs::kInquireSerial: value = identity_.serial; break;
    // CiA 305: the active node-ID, not a pending one.
    case LssCs::kInquireNodeId: value = active_node_id_; break;
    default: return false;
  }
  reply(cs, value);
  return true;
}

}  // namespace cobridge::canopen
