#include "bus/plan_runner.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include "base/number_text.hpp"
#include "canopen/nmt.hpp"
#include "canopen/sdo_abort.hpp"

namespace cobridge::bus {

namespace {

constexpr std::uint32_t kPdoInvalid = 0x80000000u;  // CiA 301 §7.5.2.35: COB-ID bit 31, PDO does not exist
constexpr std::uint8_t kComm = bit(StoreGroup::communication);

class PlanRunCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "plan_run"; }
  [[nodiscard]] std::string message(int value) const override {
    switch (static_cast<PlanRunErrc>(value)) {
      case PlanRunErrc::sdo_abort: return "the device refused an SDO transfer";
      case PlanRunErrc::sdo_timeout: return "the device did not answer";
      case PlanRunErrc::verify_mismatch: return "the value read back differs from the value written";
      case PlanRunErrc::send_failed: return "a frame could not be sent";
      case PlanRunErrc::sdo_busy: return "the SDO client is busy";
    }
    return "unknown plan_run error";
  }
};

// The coarse class of a run's failure, for whoever reports it.
Errc kind_of(PlanRunErrc code) noexcept {
  switch (code) {
    case PlanRunErrc::sdo_timeout: return Errc::kTimeout;
    case PlanRunErrc::send_failed:
    case PlanRunErrc::sdo_busy: return Errc::kUnavailable;
    case PlanRunErrc::sdo_abort:
    case PlanRunErrc::verify_mismatch: break;
  }
  return Errc::kFailed;
}

std::array<std::uint8_t, 4> little_endian(std::uint32_t v) noexcept {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16),
          static_cast<std::uint8_t>(v >> 24)};
}

}  // namespace

const std::error_category& plan_run_category() noexcept {
  static const PlanRunCategory category;
  return category;
}

std::error_code make_error_code(PlanRunErrc e) noexcept { return {static_cast<int>(e), plan_run_category()}; }

PlanRunner::PlanRunner(can::FrameSink& sink, canopen::SdoClient& sdo, ConfigPlan plan, PlanRunnerOptions options)
    : sink_(sink), sdo_(sdo), plan_(std::move(plan)), options_(options) {
  std::size_t max_entries = 0;
  for (const PlanStep& s : plan_.steps) max_entries = std::max(max_entries, s.mapping.size());
  ops_.reserve(max_entries + 4);
}

PlanRunner::~PlanRunner() {
  if (running()) sdo_.forget();
}

Error PlanRunner::start(canopen::TimePoint now) {
  if (sdo_.busy())
    return Error(kind_of(PlanRunErrc::sdo_busy), "the SDO client is busy", "device '" + plan_.device + "'",
                 make_error_code(PlanRunErrc::sdo_busy));
  if (std::error_code ec = sdo_.set_node_id(plan_.node_id))
    return Error(Errc::kInvalidArgument, ec.message(), "device '" + plan_.device + "'", ec);
  (void)sdo_.take_result();  // an old transfer's outcome is not ours
  result_ = PlanRunResult{};
  result_.steps.reserve(plan_.steps.size() + 1);
  started_at_ = now;
  step_ = 0;
  retry_at_ = canopen::kNever;
  phase_ = Phase::kNmt;  // running; begin_step sets the real phase
  begin_step(now);
  return {};
}

bool PlanRunner::on_frame(const can::Frame& frame, canopen::TimePoint now) noexcept {
  if (!running()) return false;
  const bool mine = sdo_.on_frame(frame, now);
  if (mine) drain(now);
  return mine;
}

canopen::TimePoint PlanRunner::process(canopen::TimePoint now) noexcept {
  if (!running()) return canopen::kNever;
  if (retry_at_ != canopen::kNever && now >= retry_at_) {
    retry_at_ = canopen::kNever;
    if (phase_ == Phase::kNmt) send_nmt(now);
    else launch(now);
  }
  if (!running()) return canopen::kNever;
  (void)sdo_.process(now);
  drain(now);
  if (!running()) return canopen::kNever;
  return std::min(sdo_.process(now), retry_at_);
}

// ---------------------------------------------------------------------------
// Steps

void PlanRunner::begin_step(canopen::TimePoint now) {
  if (step_ >= plan_.steps.size()) {
    finish(now);
    return;
  }
  const PlanStep& s = plan_.steps[step_];
  step_started_at_ = now;
  step_writes_ = 0;
  switch (s.kind) {
    case StepKind::nmt:
      if (s.nmt == canopen::NmtCommand::start && !options_.start_node) {
        end_step(now);
        return;
      }
      retries_left_ = options_.sdo_retries;
      send_nmt(now);
      return;
    case StepKind::write:
      writes_ = std::span<const SdoWrite>(&s.write, 1);
      write_pos_ = 0;
      on_fallback_ = false;
      begin_write(now);
      return;
    case StepKind::tpdo_mapping: begin_remap(now); return;
    case StepKind::store:
      store_pos_ = 0;
      next_store(now);
      return;
  }
}

void PlanRunner::end_step(canopen::TimePoint now) {
  result_.steps.push_back(PlanStepTiming{plan_.steps[step_].label, now - step_started_at_, step_writes_});
  ++step_;
  begin_step(now);
}

void PlanRunner::send_nmt(canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  phase_ = Phase::kNmt;
  if (sink_.send(canopen::make_nmt(s.nmt, plan_.node_id))) {
    if (s.nmt == canopen::NmtCommand::start) result_.started = true;
    end_step(now);
    return;
  }
  if (retries_left_ > 0) {
    --retries_left_;
    ++result_.retries;
    retry_at_ = now + options_.tx_retry;
    return;
  }
  fail(PlanRunErrc::send_failed, where() + "NMT " + std::string(canopen::to_string(s.nmt)) + " could not be sent", now);
}

void PlanRunner::begin_write(canopen::TimePoint now) {
  const SdoWrite& w = writes_[write_pos_];
  verify_now_ = w.verify && w.read_first;
  if (w.read_first) {
    phase_ = Phase::kWriteRead;
    upload(w.index, w.sub, now);
    return;
  }
  written_ = w.value & w.size_mask();
  phase_ = Phase::kWriteDownload;
  download(w.index, w.sub, written_, w.size, now);
}

void PlanRunner::next_write(canopen::TimePoint now) {
  ++write_pos_;
  if (write_pos_ < writes_.size()) begin_write(now);
  else end_step(now);
}

void PlanRunner::begin_remap(canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  mapping_differs_ = false;
  phase_ = Phase::kMapReadCob;
  upload(s.comm_index, 1, now);
}

void PlanRunner::next_store(canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  const bool always = plan_.store_policy == config::StorePolicy::always;
  while (store_pos_ < s.store.size()) {
    const StoreTarget& t = s.store[store_pos_];
    if (always || (t.groups & result_.changed_groups) != 0) {
      phase_ = Phase::kStore;
      download(0x1010, t.sub, device::kSaveSignature, 4, now);
      return;
    }
    ++store_pos_;
  }
  end_step(now);
}

// ---------------------------------------------------------------------------
// Transfers

void PlanRunner::upload(std::uint16_t index, std::uint8_t sub, canopen::TimePoint now) {
  transfer_ = Transfer{true, index, sub, 0, 0};
  retries_left_ = options_.sdo_retries;
  launch(now);
}

void PlanRunner::download(std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size,
                          canopen::TimePoint now) {
  transfer_ = Transfer{false, index, sub, value, size};
  retries_left_ = options_.sdo_retries;
  launch(now);
}

void PlanRunner::launch(canopen::TimePoint now) {
  std::error_code ec;
  if (transfer_.upload) {
    ec = sdo_.start_upload(transfer_.index, transfer_.sub, now);
  } else {
    const auto bytes = little_endian(transfer_.value);
    ec = sdo_.start_download(transfer_.index, transfer_.sub,
                             std::span<const std::uint8_t>(bytes.data(), std::min<std::size_t>(transfer_.size, 4)), now);
  }
  if (!ec) return;
  if (ec == std::errc::no_buffer_space && retries_left_ > 0) {
    --retries_left_;
    ++result_.retries;
    retry_at_ = now + options_.tx_retry;
    return;
  }
  fail(PlanRunErrc::send_failed,
       where() + (transfer_.upload ? "reading " : "writing ") + object_text(transfer_.index, transfer_.sub) + ": " +
           ec.message(),
       now, ec);
}

void PlanRunner::drain(canopen::TimePoint now) {
  while (running()) {
    auto r = sdo_.take_result();
    if (!r) return;
    on_result(*r, now);
  }
}

void PlanRunner::on_result(const canopen::SdoClient::Result& r, canopen::TimePoint now) {
  if (r.ok()) {
    if (r.direction == canopen::SdoClient::Direction::kUpload) ++result_.reads;
    on_success(r.as_u32(), now);
    return;
  }
  if (r.error == canopen::SdoAbort::kProtocolTimedOut && retries_left_ > 0) {
    --retries_left_;
    ++result_.retries;
    launch(now);
    return;
  }
  on_failure(r, now);
}

void PlanRunner::on_success(std::uint32_t value, canopen::TimePoint now) {
  switch (phase_) {
    case Phase::kWriteRead:
    case Phase::kWriteDownload:
    case Phase::kWriteVerify: on_write_answer(value, now); return;
    case Phase::kMapReadCob:
    case Phase::kMapReadCount:
    case Phase::kMapReadEntry: on_mapping_read(value, now); return;
    case Phase::kMapDownload: on_mapping_written(now); return;
    case Phase::kMapVerifyCount:
    case Phase::kMapVerifyEntry:
    case Phase::kMapVerifyCob: on_mapping_verify(value, now); return;
    case Phase::kStore:
      ++result_.saves;
      result_.stored = true;
      ++store_pos_;
      next_store(now);
      return;
    case Phase::kIdle:
    case Phase::kNmt:
    case Phase::kDone: return;
  }
}

// A value write: read what is there, write only what differs, read it back.
void PlanRunner::on_write_answer(std::uint32_t value, canopen::TimePoint now) {
  const SdoWrite& w = writes_[write_pos_];
  if (phase_ == Phase::kWriteRead) {
    const std::uint32_t current = value & w.size_mask();
    if (((current ^ w.value) & w.owned()) == 0) {
      next_write(now);
      return;
    }
    if (result_.differed.size() < PlanRunResult::kMaxDiffered) {
      result_.differed.push_back(object_text(w.index, w.sub) + " read " + hex(current & w.owned(), 8) + ", configured " +
                                 hex(w.value & w.owned(), 8));
    }
    written_ = w.merged(current);
    phase_ = Phase::kWriteDownload;
    download(w.index, w.sub, written_, w.size, now);
    return;
  }
  if (phase_ == Phase::kWriteDownload) {
    ++result_.writes;
    ++step_writes_;
    result_.changed_groups |= w.groups;
    if (!verify_now_) {
      next_write(now);
      return;
    }
    phase_ = Phase::kWriteVerify;
    upload(w.index, w.sub, now);
    return;
  }
  const std::uint32_t read = value & w.size_mask();
  if (((read ^ written_) & w.owned()) != 0) {
    fail(PlanRunErrc::verify_mismatch,
         where() + object_text(w.index, w.sub) + " written " + hex(written_, 8) + " but read back " + hex(read, 8), now);
    return;
  }
  next_write(now);
}

// A PDO mapping: its COB-ID, count and entries as the device has them.
void PlanRunner::on_mapping_read(std::uint32_t value, canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  if (phase_ == Phase::kMapReadCob) {
    cob_id_ = value;
    phase_ = Phase::kMapReadCount;
    upload(s.map_index, 0, now);
    return;
  }
  if (phase_ == Phase::kMapReadCount) {
    if ((value & 0xFFu) != s.mapping.size()) mapping_differs_ = true;
    entry_pos_ = 0;
  } else {
    if (value != s.mapping[entry_pos_]) mapping_differs_ = true;
    ++entry_pos_;
  }
  if (!mapping_differs_ && entry_pos_ < s.mapping.size()) {
    phase_ = Phase::kMapReadEntry;
    upload(s.map_index, static_cast<std::uint8_t>(entry_pos_ + 1), now);
    return;
  }
  plan_mapping_writes(s);
  if (ops_.empty()) {
    end_step(now);
    return;
  }
  op_pos_ = 0;
  phase_ = Phase::kMapDownload;
  transfer_ = ops_[0];
  retries_left_ = options_.sdo_retries;
  launch(now);
}

// J§1.7.2 / E§8.2 steps 1-5, or only the COB-ID when just its bit 31 is wrong.
void PlanRunner::plan_mapping_writes(const PlanStep& s) {
  ops_.clear();
  const std::uint32_t disabled = cob_id_ | kPdoInvalid;
  const std::uint32_t enabled = cob_id_ & ~kPdoInvalid;
  const bool wanted = !s.mapping.empty();
  if (mapping_differs_) {
    ops_.push_back(Transfer{false, s.comm_index, 1, disabled, 4});
    ops_.push_back(Transfer{false, s.map_index, 0, 0, 1});
    for (std::size_t i = 0; i < s.mapping.size(); ++i)
      ops_.push_back(Transfer{false, s.map_index, static_cast<std::uint8_t>(i + 1), s.mapping[i], 4});
    if (wanted) {
      ops_.push_back(Transfer{false, s.map_index, 0, static_cast<std::uint32_t>(s.mapping.size()), 1});
      ops_.push_back(Transfer{false, s.comm_index, 1, enabled, 4});
    }
  } else if (wanted && cob_id_ != enabled) {
    ops_.push_back(Transfer{false, s.comm_index, 1, enabled, 4});
  } else if (!wanted && cob_id_ != disabled) {
    ops_.push_back(Transfer{false, s.comm_index, 1, disabled, 4});
  }
}

void PlanRunner::on_mapping_written(canopen::TimePoint now) {
  ++result_.writes;
  ++step_writes_;
  result_.changed_groups |= kComm;
  ++op_pos_;
  if (op_pos_ < ops_.size()) {
    transfer_ = ops_[op_pos_];
    retries_left_ = options_.sdo_retries;
    launch(now);
    return;
  }
  phase_ = Phase::kMapVerifyCount;
  upload(plan_.steps[step_].map_index, 0, now);
}

// The mapping read back after writing it: count, entries, then the COB-ID.
void PlanRunner::on_mapping_verify(std::uint32_t value, canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  if (phase_ == Phase::kMapVerifyCob) {
    const std::uint32_t expected = s.mapping.empty() ? (cob_id_ | kPdoInvalid) : (cob_id_ & ~kPdoInvalid);
    if (value != expected) {
      fail(PlanRunErrc::verify_mismatch,
           where() + object_text(s.comm_index, 1) + " written " + hex(expected, 8) + " but read back " + hex(value, 8), now);
      return;
    }
    end_step(now);
    return;
  }
  if (phase_ == Phase::kMapVerifyCount) {
    if ((value & 0xFFu) != s.mapping.size()) {
      fail(PlanRunErrc::verify_mismatch,
           where() + object_text(s.map_index, 0) + " written " + std::to_string(s.mapping.size()) +
               " entries but read back " + std::to_string(value & 0xFFu),
           now);
      return;
    }
    entry_pos_ = 0;
  } else {
    if (value != s.mapping[entry_pos_]) {
      fail(PlanRunErrc::verify_mismatch,
           where() + object_text(s.map_index, static_cast<std::uint8_t>(entry_pos_ + 1)) + " written " +
               hex(s.mapping[entry_pos_], 8) + " but read back " + hex(value, 8),
           now);
      return;
    }
    ++entry_pos_;
  }
  if (entry_pos_ < s.mapping.size()) {
    phase_ = Phase::kMapVerifyEntry;
    upload(s.map_index, static_cast<std::uint8_t>(entry_pos_ + 1), now);
  } else {
    phase_ = Phase::kMapVerifyCob;
    upload(s.comm_index, 1, now);
  }
}

void PlanRunner::on_failure(const canopen::SdoClient::Result& r, canopen::TimePoint now) {
  const PlanStep& s = plan_.steps[step_];
  const bool timeout = r.error == canopen::SdoAbort::kProtocolTimedOut;
  if (phase_ == Phase::kWriteRead && r.error == canopen::SdoAbort::kWriteOnly) {
    // Nothing to compare with: write it, without a read-back.
    const SdoWrite& w = writes_[write_pos_];
    written_ = w.value & w.size_mask();
    verify_now_ = false;
    phase_ = Phase::kWriteDownload;
    download(w.index, w.sub, written_, w.size, now);
    return;
  }
  if (phase_ == Phase::kWriteDownload && !timeout && !on_fallback_ && !s.fallback.empty()) {
    on_fallback_ = true;
    result_.guarding_fallback = true;
    writes_ = std::span<const SdoWrite>(s.fallback);
    write_pos_ = 0;
    begin_write(now);
    return;
  }
  std::string action = transfer_.upload ? "reading " + object_text(transfer_.index, transfer_.sub)
                                        : "writing " + object_text(transfer_.index, transfer_.sub) + " = " +
                                              hex(transfer_.value, transfer_.size * 2);
  const std::uint32_t code = canopen::sdo_abort_wire_code(r.error);
  std::string detail = "SDO abort " + hex(code, 8) + " (" + std::string(canopen::sdo_abort_text(code)) + ")";
  if (timeout) {
    detail = "no answer after " + std::to_string(options_.sdo_retries + 1u) + " attempts (" + detail + ")";
  }
  fail(timeout ? PlanRunErrc::sdo_timeout : PlanRunErrc::sdo_abort, where() + action + ": " + detail, now, r.error);
}

void PlanRunner::fail(PlanRunErrc code, std::string message, canopen::TimePoint now, std::error_code sdo) {
  result_.error = Error(kind_of(code), std::move(message), {}, make_error_code(code));
  result_.sdo_error = sdo;
  if (step_ < plan_.steps.size())
    result_.steps.push_back(PlanStepTiming{plan_.steps[step_].label, now - step_started_at_, step_writes_});
  finish(now);
}

void PlanRunner::finish(canopen::TimePoint now) {
  result_.duration = now - started_at_;
  retry_at_ = canopen::kNever;
  phase_ = Phase::kDone;
}

std::string PlanRunner::where() const {
  std::string label = step_ < plan_.steps.size() ? plan_.steps[step_].label : std::string{};
  if (on_fallback_ && step_ < plan_.steps.size()) label += ": " + plan_.steps[step_].fallback_label;
  return "device '" + plan_.device + "': " + label + ": ";
}

}  // namespace cobridge::bus
