#include "canopen/lss_master.hpp"

#include <algorithm>
#include <string>

namespace cobridge::canopen {

namespace {

// A scan begins again twice at most: a third failure says the waits are
// not what fails (the slave left, or the bus loses frames).
constexpr uint32_t kMaxScanRestarts = 2;

class LssCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "lss"; }
  [[nodiscard]] std::string message(int ev) const override {
    switch (static_cast<LssErrc>(ev)) {
      case LssErrc::kBusy: return "LSS master busy with another operation";
      case LssErrc::kSendFailed: return "LSS frame could not be queued for sending";
      case LssErrc::kInvalidArgument: return "invalid LSS request";
      case LssErrc::kTimeout: return "no LSS answer within the timeout";
      case LssErrc::kNotFound: return "no matching LSS slave answered";
      case LssErrc::kFastscanLost: return "LSS Fastscan: the slave stopped answering during the scan";
      case LssErrc::kFastscanUnconfirmed:
        return "LSS Fastscan: no slave confirmed the identity found (switch selective unanswered)";
    }
    return "unknown LSS error";
  }
};

std::string service_name(uint8_t cs) {
  switch (static_cast<LssCs>(cs)) {
    case LssCs::kConfigureNodeId: return "configure node-ID";
    case LssCs::kConfigureBitTiming: return "configure bit timing";
    case LssCs::kStoreConfiguration: return "store configuration";
    default: return "LSS service 0x" + std::to_string(cs);
  }
}

// Texts of J§1.5.1-1.5.3 / E§6.1-6.3, completed from CiA 305.
std::string slave_error_text(uint8_t cs, uint8_t code) {
  if (code == 0) return "success";
  if (code == 0xFF) return "manufacturer-specific error (see byte 2)";
  switch (static_cast<LssCs>(cs)) {
    case LssCs::kConfigureNodeId:
      if (code == static_cast<uint8_t>(LssNodeIdError::kOutOfRange)) return "node-ID out of range";
      break;
    case LssCs::kConfigureBitTiming:
      if (code == static_cast<uint8_t>(LssBitTimingError::kNotSupported)) return "bit timing not supported";
      break;
    case LssCs::kStoreConfiguration:
      if (code == static_cast<uint8_t>(LssStoreError::kNotSupported)) return "store configuration not supported";
      if (code == static_cast<uint8_t>(LssStoreError::kMediaAccess)) return "storage media access error";
      break;
    default: break;
  }
  return "reserved error code " + std::to_string(code);
}

class LssSlaveErrorCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "lss_slave"; }
  [[nodiscard]] std::string message(int ev) const override {
    const auto cs = static_cast<uint8_t>((ev >> 8) & 0xFF);
    const auto code = static_cast<uint8_t>(ev & 0xFF);
    return service_name(cs) + ": " + slave_error_text(cs, code);
  }
};

constexpr uint8_t kLastField = kLssFieldCount - 1;

}  // namespace

const std::error_category& lss_category() noexcept {
  static const LssCategory category;
  return category;
}

std::error_code make_error_code(LssErrc e) noexcept { return {static_cast<int>(e), lss_category()}; }

const std::error_category& lss_slave_error_category() noexcept {
  static const LssSlaveErrorCategory category;
  return category;
}

std::error_code make_lss_slave_error(LssCs service, uint8_t code) noexcept {
  return {(static_cast<int>(service) << 8) | code, lss_slave_error_category()};
}

LssMaster::LssMaster(can::FrameSink& sink, Config config) noexcept
    : sink_(sink),
      config_(config),
      timing_(config.min_timeout > Duration::zero() ? config.min_timeout : config.timeout, config.timeout) {}

bool LssMaster::send(const can::Frame& f) noexcept {
  if (!sink_.send(f)) return false;
  ++current_.frames_sent;
  return true;
}

bool LssMaster::send_lss(LssCs cs, uint32_t value, uint8_t b5, uint8_t b6, uint8_t b7) noexcept {
  return send(lss_frame(cob::kLssMasterToSlave, static_cast<uint8_t>(cs), value, b5, b6, b7));
}

bool LssMaster::send_identify(const LssRange& r) noexcept {
  return send_lss(LssCs::kIdentifyVendor, r.vendor) && send_lss(LssCs::kIdentifyProduct, r.product) &&
         send_lss(LssCs::kIdentifyRevisionLow, r.rev_lo) && send_lss(LssCs::kIdentifyRevisionHigh, r.rev_hi) &&
         send_lss(LssCs::kIdentifySerialLow, r.serial_lo) && send_lss(LssCs::kIdentifySerialHigh, r.serial_hi);
}

bool LssMaster::send_switch_selective(const LssAddress& a) noexcept {
  return send_lss(LssCs::kSwitchSelectiveVendor, a.vendor) &&
         send_lss(LssCs::kSwitchSelectiveProduct, a.product) &&
         send_lss(LssCs::kSwitchSelectiveRevision, a.revision) &&
         send_lss(LssCs::kSwitchSelectiveSerial, a.serial);
}

std::error_code LssMaster::begin(LssOperation op, TimePoint now) noexcept {
  if (busy()) return LssErrc::kBusy;
  result_.reset();
  current_ = Result{};
  current_.operation = op;
  started_ = now;
  careful_ = false;
  return {};
}

void LssMaster::arm(Phase phase, LssCs expect, TimePoint now) noexcept {
  phase_ = phase;
  expect_ = expect;
  answered_ = false;
  step_sent_ = now;
  step_sent_stamp_ns_ = config_.stamp_clock_ns != nullptr ? config_.stamp_clock_ns() : 0;
  ++current_.steps;
  // The first step of an operation (Fastscan probe, identify, Slowscan
  // probe) decides "nobody there": it always waits the full timeout, and
  // its answers teach the waits of the steps that follow.
  // A scan begun again (restart) asks again from its probe.
  // The verification of a Fastscan's result waits the full timeout too: a
  // slow answer taken for silence would cost a whole scan.
  const bool first = current_.steps == 1 || phase == Phase::kFastscanProbe || phase == Phase::kSlowscanProbe ||
                     phase == Phase::kFastscanVerify;
  const bool learnt = search_phase() && !first && timing_.learning();
  deadline_ = now + (learnt ? search_wait() : config_.timeout);
}

// A scan begun again (careful_) waits 4 x the learnt wait for silence,
// within the timeout: the late answer that spoilt the first pass is then
// caught, without paying the full timeout for every 1-bit of every field.
Duration LssMaster::search_wait() const noexcept {
  const Duration w = timing_.no_answer_wait();
  return careful_ ? std::min(config_.timeout, 4 * w) : w;
}

bool LssMaster::search_phase() const noexcept {
  return phase_ != Phase::kIdle && phase_ != Phase::kAwaitReply;
}

void LssMaster::finish(std::error_code ec, TimePoint now) noexcept {
  current_.error = ec;
  current_.elapsed = now - started_;
  result_ = current_;
  phase_ = Phase::kIdle;
  deadline_ = kNever;
}

void LssMaster::cancel() noexcept {
  phase_ = Phase::kIdle;
  deadline_ = kNever;
}

std::optional<LssMaster::Result> LssMaster::take_result() noexcept {
  auto r = result_;
  result_.reset();
  return r;
}

std::error_code LssMaster::switch_state_global(LssMode mode) noexcept {
  if (busy()) return LssErrc::kBusy;
  if (!sink_.send(lss_frame(cob::kLssMasterToSlave, static_cast<uint8_t>(LssCs::kSwitchStateGlobal),
                            static_cast<uint8_t>(mode))))
    return LssErrc::kSendFailed;
  return {};
}

std::error_code LssMaster::activate_bit_timing(uint16_t switch_delay_ms) noexcept {
  if (busy()) return LssErrc::kBusy;
  if (!sink_.send(lss_frame(cob::kLssMasterToSlave, static_cast<uint8_t>(LssCs::kActivateBitTiming),
                            switch_delay_ms)))
    return LssErrc::kSendFailed;
  return {};
}

std::error_code LssMaster::switch_state_selective(const LssAddress& address, TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kSwitchSelective, now)) return ec;
  current_.address = address;
  if (!send_switch_selective(address)) return LssErrc::kSendFailed;
  arm(Phase::kAwaitReply, LssCs::kSwitchSelectiveResponse, now);
  return {};
}

std::error_code LssMaster::configure_node_id(uint8_t node_id, TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kConfigureNodeId, now)) return ec;
  if (!send_lss(LssCs::kConfigureNodeId, node_id)) return LssErrc::kSendFailed;
  arm(Phase::kAwaitReply, LssCs::kConfigureNodeId, now);
  return {};
}

std::error_code LssMaster::configure_bit_timing(uint8_t table_index, TimePoint now,
                                                uint8_t table_selector) noexcept {
  if (auto ec = begin(LssOperation::kConfigureBitTiming, now)) return ec;
  const auto value = static_cast<uint32_t>(table_selector | (table_index << 8));
  if (!send_lss(LssCs::kConfigureBitTiming, value)) return LssErrc::kSendFailed;
  arm(Phase::kAwaitReply, LssCs::kConfigureBitTiming, now);
  return {};
}

std::error_code LssMaster::store_configuration(TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kStoreConfiguration, now)) return ec;
  if (!send_lss(LssCs::kStoreConfiguration)) return LssErrc::kSendFailed;
  arm(Phase::kAwaitReply, LssCs::kStoreConfiguration, now);
  return {};
}

std::error_code LssMaster::inquire(LssCs what, TimePoint now) noexcept {
  const auto cs = static_cast<uint8_t>(what);
  if (cs < static_cast<uint8_t>(LssCs::kInquireVendor) || cs > static_cast<uint8_t>(LssCs::kInquireNodeId))
    return LssErrc::kInvalidArgument;
  if (auto ec = begin(LssOperation::kInquire, now)) return ec;
  if (!send_lss(what)) return LssErrc::kSendFailed;
  arm(Phase::kAwaitReply, what, now);
  return {};
}

std::error_code LssMaster::identify_remote_slave(const LssRange& range, TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kIdentifyRemoteSlave, now)) return ec;
  if (!send_identify(range)) return LssErrc::kSendFailed;
  arm(Phase::kCollect, LssCs::kIdentifySlave, now);
  return {};
}

std::error_code LssMaster::identify_non_configured(TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kIdentifyNonConfigured, now)) return ec;
  if (!send_lss(LssCs::kIdentifyNonConfigured)) return LssErrc::kSendFailed;
  arm(Phase::kCollect, LssCs::kIdentifyNonConfiguredSlave, now);
  return {};
}

FastscanPlan LssMaster::FastscanKnown::to_plan() const noexcept {
  FastscanPlan p;
  (void)p.add(FastscanTarget::of(vendor, product, revision, serial));
  return p;
}

std::error_code LssMaster::fastscan(TimePoint now, const FastscanKnown& known) noexcept {
  return fastscan(now, known.to_plan());
}

std::error_code LssMaster::fastscan(TimePoint now, const FastscanPlan& plan) noexcept {
  if (auto ec = begin(LssOperation::kFastscan, now)) return ec;
  plan_ = plan;
  if (!fastscan_probe(now)) return LssErrc::kSendFailed;
  return {};
}

// The reset (BitChecked 0x80) sends every non-configured slave back to the
// first field (LSSPos 0), whatever field each had reached.
bool LssMaster::fastscan_probe(TimePoint now) noexcept {
  if (!send_lss(LssCs::kFastscan, 0, kLssFastscanReset, 0, 0)) return false;
  arm(Phase::kFastscanProbe, LssCs::kIdentifySlave, now);
  return true;
}

std::error_code LssMaster::slowscan(const LssRange& bounds, TimePoint now) noexcept {
  if (auto ec = begin(LssOperation::kSlowscan, now)) return ec;
  ss_bounds_ = bounds;
  if (!slowscan_probe(now)) return LssErrc::kSendFailed;
  return {};
}

bool LssMaster::slowscan_probe(TimePoint now) noexcept {
  ss_range_ = ss_bounds_;
  if (!send_identify(ss_range_)) return false;
  arm(Phase::kSlowscanProbe, LssCs::kIdentifySlave, now);
  return true;
}

// Slowscan's switch selective unanswered: a halving step decided on a late
// answer led the search away from the slave. It begins again from its
// bounds with longer waits, as a Fastscan does (kMaxScanRestarts).
void LssMaster::on_reply_missing(TimePoint now) noexcept {
  if (current_.operation != LssOperation::kSlowscan || !begin_again()) return finish(LssErrc::kTimeout, now);
  if (!slowscan_probe(now)) finish(LssErrc::kSendFailed, now);
}

// The one rule for a scan begun again: only with learnt waits (fixed ones
// would fail the same way), twice at most, and from then on carefully.
bool LssMaster::begin_again() noexcept {
  if (!timing_.learning() || current_.restarts >= kMaxScanRestarts) return false;
  careful_ = true;
  ++current_.restarts;
  return true;
}

// When an answer came, on the master's clock: its kernel stamp's distance
// from the step's send, where both have a stamp; else `now`. Never after
// `now` nor before the send (a step of the wall clock in between).
TimePoint LssMaster::answered_at(const can::Frame& f, TimePoint now) const noexcept {
  if (step_sent_stamp_ns_ == 0 || f.timestamp_ns == 0) return now;
  const Duration since_sent = std::chrono::nanoseconds(std::max<int64_t>(0, f.timestamp_ns - step_sent_stamp_ns_));
  return std::min(now, step_sent_ + since_sent);
}

bool LssMaster::on_frame(const can::Frame& f, TimePoint now) noexcept {
  if (!is_lss_frame(f, cob::kLssSlaveToMaster)) return false;
  if (phase_ == Phase::kIdle || f.data[0] != static_cast<uint8_t>(expect_)) return true;
  // Answers that came after the deadline belong to a step already decided.
  const TimePoint at = answered_at(f, now);
  if (at > deadline_) return true;
  ++current_.answers;
  timing_.record(at - step_sent_);
  if (phase_ == Phase::kFastscanVerify) {
    finish({}, now);  // the slave found is there, in configuration state again
    return true;
  }
  if (phase_ != Phase::kAwaitReply) {
    // Answered: the others' answers to this step come within the slowest
    // answer time seen; then the step is decided (AnswerTiming). Identical
    // answers do not merge on vcan (32 slaves: 32 frames, one after the
    // other): every answer keeps the step open that long again, within the
    // timeout, so that a burst belongs to the step that caused it and does
    // not spill into the next one.
    if (timing_.learning()) {
      const TimePoint quiet = at + (careful_ ? timing_.no_answer_wait() : timing_.settle());
      deadline_ = answered_ ? std::min(std::max(quiet, deadline_), step_sent_ + config_.timeout)
                            : std::min(deadline_, quiet);
    }
    answered_ = true;
    return true;
  }
  switch (current_.operation) {
    case LssOperation::kConfigureNodeId:
    case LssOperation::kConfigureBitTiming:
    case LssOperation::kStoreConfiguration:
      current_.slave_error = f.data[1];
      current_.slave_spec_error = f.data[2];
      finish(f.data[1] == 0 ? std::error_code{} : make_lss_slave_error(expect_, f.data[1]), now);
      break;
    case LssOperation::kInquire:
      current_.value = expect_ == LssCs::kInquireNodeId ? f.data[1] : lss_value(f);
      finish({}, now);
      break;
    default:  // switch selective, and the last step of Slowscan
      finish({}, now);
      break;
  }
  return true;
}

TimePoint LssMaster::process(TimePoint now) noexcept {
  if (phase_ == Phase::kIdle) return kNever;
  if (now < deadline_) return deadline_;
  on_step_done(now);
  return deadline_;
}

void LssMaster::on_step_done(TimePoint now) noexcept {
  if (!answered_) ++current_.silent_steps;
  switch (phase_) {
    case Phase::kIdle: return;
    case Phase::kAwaitReply: on_reply_missing(now); return;
    case Phase::kCollect:
      current_.answered = answered_;
      finish({}, now);
      return;
    case Phase::kFastscanProbe:
      if (!answered_) return finish(LssErrc::kNotFound, now);
      fastscan_field(0, now);
      return;
    case Phase::kFastscanBit: {
      // Slaves answer when their bit equals the 0 we sent; silence means 1.
      if (!answered_) {
        const auto field = static_cast<LssField>(fs_field_);
        current_.address.set_field(field, current_.address.field(field) | (1u << fs_bit_));
      }
      if (fs_bit_ == 0) return fastscan_confirm(now);
      --fs_bit_;
      fastscan_bit_step(now);
      return;
    }
    case Phase::kFastscanConfirm: return fastscan_confirm_done(now);
    case Phase::kFastscanVerify: return fastscan_unverified(now);
    case Phase::kSlowscanProbe:
      if (!answered_) return finish(LssErrc::kNotFound, now);
      phase_ = Phase::kSlowscanRevision;
      ss_lo_ = ss_range_.rev_lo;
      ss_hi_ = ss_range_.rev_hi;
      slowscan_step(now);
      return;
    case Phase::kSlowscanRevision:
    case Phase::kSlowscanSerial:
      if (answered_)
        ss_hi_ = ss_mid_;
      else
        ss_lo_ = ss_mid_ + 1;
      slowscan_step(now);
      return;
  }
}

void LssMaster::fastscan_field(uint8_t field, TimePoint now) noexcept {
  fs_field_ = field;
  fs_tried_ = 0;
  fastscan_next_guess(now);
}

// Confirms the plan's next candidate for the field; with none left, searches
// the field when the plan allows it, else no slave of the plan is there.
void LssMaster::fastscan_next_guess(TimePoint now) noexcept {
  const auto f = static_cast<LssField>(fs_field_);
  if (const auto v = plan_.next_candidate(current_.address, fs_field_, fs_tried_)) {
    current_.address.set_field(f, *v);
    fs_guess_ = true;
    fastscan_confirm(now);
    return;
  }
  if (!plan_.may_search(current_.address, fs_field_)) return fastscan_not_found(now);
  fastscan_search(now);
}

// No slave of the plan answered; or one did, later than the wait, to a
// guessed serial's confirm (the last): it matched and is in configuration
// state, deaf to Fastscan and identify non-configured for good. Switch
// state global waiting brings it back for the next round; every other slave
// is waiting already.
void LssMaster::fastscan_not_found(TimePoint now) noexcept {
  if (fs_field_ == kLastField && !send_lss(LssCs::kSwitchStateGlobal, static_cast<uint8_t>(LssMode::kWaiting)))
    return finish(LssErrc::kSendFailed, now);
  finish(LssErrc::kNotFound, now);
}

void LssMaster::fastscan_search(TimePoint now) noexcept {
  fs_guess_ = false;
  current_.address.set_field(static_cast<LssField>(fs_field_), 0);
  fs_bit_ = 31;
  fastscan_bit_step(now);
}

void LssMaster::fastscan_confirm_done(TimePoint now) noexcept {
  if (answered_) {
    if (fs_field_ == kLastField) return fastscan_verify(now);
    return fastscan_field(static_cast<uint8_t>(fs_field_ + 1), now);
  }
  if (fs_guess_) return fastscan_next_guess(now);  // a wrong guess: nobody moved on
  // A bit decided on a late answer (taken for the next step's), or this
  // confirm's own answer late: then the slave did match and moved on to the
  // next field, and would ignore a search of this one; after the serial's
  // confirm it is in configuration state, where it ignores Fastscan and
  // identify non-configured alike, for good. Switch state global waiting
  // brings that one back, the reset every other: the scan begins again, with
  // longer waits; or, with no restart left, ends with every slave waiting.
  if (!send_lss(LssCs::kSwitchStateGlobal, static_cast<uint8_t>(LssMode::kWaiting)))
    return finish(LssErrc::kSendFailed, now);
  if (!begin_again()) return finish(LssErrc::kFastscanLost, now);
  if (!fastscan_probe(now)) finish(LssErrc::kSendFailed, now);
}

// The slave found entered configuration state with the last confirm. Back
// to waiting, then switch selective to the identity found: the answer (0x44)
// can only come from the slave that has it.
void LssMaster::fastscan_verify(TimePoint now) noexcept {
  const bool sent = send_lss(LssCs::kSwitchStateGlobal, static_cast<uint8_t>(LssMode::kWaiting)) &&
                    send_switch_selective(current_.address);
  if (!sent) return finish(LssErrc::kSendFailed, now);
  arm(Phase::kFastscanVerify, LssCs::kSwitchSelectiveResponse, now);
}

// Nobody has the identity found: a late answer decided a bit and a confirm.
// The scan begins again from its reset, carefully.
void LssMaster::fastscan_unverified(TimePoint now) noexcept {
  if (!begin_again()) return finish(LssErrc::kFastscanUnconfirmed, now);
  if (!fastscan_probe(now)) finish(LssErrc::kSendFailed, now);
}

void LssMaster::fastscan_bit_step(TimePoint now) noexcept {
  const uint32_t id = current_.address.field(static_cast<LssField>(fs_field_));
  if (!send_lss(LssCs::kFastscan, id, fs_bit_, fs_field_, fs_field_)) return finish(LssErrc::kSendFailed, now);
  arm(Phase::kFastscanBit, LssCs::kIdentifySlave, now);
}

void LssMaster::fastscan_confirm(TimePoint now) noexcept {
  const uint32_t id = current_.address.field(static_cast<LssField>(fs_field_));
  // LSSNext wraps to 0 after the serial: that tells the slave its whole
  // address matched and it enters configuration state.
  const auto next = static_cast<uint8_t>((fs_field_ + 1) % kLssFieldCount);
  if (!send_lss(LssCs::kFastscan, id, 0, fs_field_, next)) return finish(LssErrc::kSendFailed, now);
  arm(Phase::kFastscanConfirm, LssCs::kIdentifySlave, now);
}

void LssMaster::slowscan_step(TimePoint now) noexcept {
  // Invariant: at least one matching slave lies in [ss_lo_, ss_hi_] of the
  // field being searched, so halving keeps the lower half when it answers.
  for (;;) {
    if (ss_lo_ != ss_hi_) {
      ss_mid_ = ss_lo_ + (ss_hi_ - ss_lo_) / 2;
      LssRange probe = ss_range_;
      if (phase_ == Phase::kSlowscanRevision) {
        probe.rev_lo = ss_lo_;
        probe.rev_hi = ss_mid_;
      } else {
        probe.serial_lo = ss_lo_;
        probe.serial_hi = ss_mid_;
      }
      if (!send_identify(probe)) return finish(LssErrc::kSendFailed, now);
      arm(phase_, LssCs::kIdentifySlave, now);
      return;
    }
    if (phase_ == Phase::kSlowscanRevision) {
      ss_range_.rev_lo = ss_range_.rev_hi = ss_lo_;
      phase_ = Phase::kSlowscanSerial;
      ss_lo_ = ss_range_.serial_lo;
      ss_hi_ = ss_range_.serial_hi;
      continue;
    }
    ss_range_.serial_lo = ss_range_.serial_hi = ss_lo_;
    current_.address = LssAddress{ss_range_.vendor, ss_range_.product, ss_range_.rev_lo, ss_lo_};
    if (!send_switch_selective(current_.address)) return finish(LssErrc::kSendFailed, now);
    arm(Phase::kAwaitReply, LssCs::kSwitchSelectiveResponse, now);
    return;
  }
}

}  // namespace cobridge::canopen
