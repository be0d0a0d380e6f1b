// PlanRunner: executes one ConfigPlan on one device through an SDO client,
// as a non-blocking state machine in the style of the protocol components:
// start(now), feed every received frame to on_frame(), call process(now) by
// the deadline it returns, read result() once finished().
//
// For every write it first reads the current value and writes only when the
// bits the plan owns differ, then reads the value back and compares (a value
// that does not stick is an error naming the object, the value written and
// the value read). A TPDO mapping is compared entry by entry; when it differs
// the manuals' whole remapping procedure runs (J§1.7.2, E§8.2): COB-ID bit 31
// set (the other bits, e.g. the RTR bit, kept as read), 0x1A0x/0 = 0, the
// entries, the count, bit 31 cleared; then the mapping is read back. 'save'
// goes only to the 0x1010 sub-indices whose parameters changed (policy
// on-change) or to all the plan names (policy always), so an unchanged device
// is not rewritten and its flash is spared. An SDO transfer is repeated only
// after a timeout (0x05040000), at most `sdo_retries` times; an abort from the
// device ends the run, except for a write the plan gives a fallback (the
// rotary series' heartbeat → node guarding).
//
// Thread: driven by the bus manager's control thread that owns the SDO client
// and receives the device's frames. Never blocks, never reads a clock;
// on_frame() and process() do not allocate except to format an error message
// or record a step timing (reserved at start()).
#pragma once

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "base/error.hpp"
#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/sdo_client.hpp"
#include "bus/config_plan.hpp"

namespace cobridge::bus {

enum class PlanRunErrc {
  sdo_abort = 1,     // the device refused a read or write (SDO abort; see sdo_error)
  sdo_timeout,       // no answer after the retries
  verify_mismatch,   // the value read back differs from the value written
  send_failed,       // the frame could not be queued (after the retries)
  sdo_busy,          // the SDO client was in use when start() was called
};
[[nodiscard]] const std::error_category& plan_run_category() noexcept;
[[nodiscard]] std::error_code make_error_code(PlanRunErrc e) noexcept;

struct PlanStepTiming {
  std::string label;
  canopen::Duration duration{};
  std::uint32_t writes = 0;
};

// What a run did, and (error set) why it stopped: error.code is a
// PlanRunErrc, error.message "device 'lift': cam 1 low: ...".
struct PlanRunResult {
  Error error;                // kOk on success
  std::error_code sdo_error;  // the SDO abort behind sdo_abort / sdo_timeout
  std::uint32_t writes = 0;   // values changed on the device (remap sub-steps included, 'save' not)
  std::uint32_t reads = 0;
  std::uint32_t saves = 0;    // 'save' signatures written
  std::uint32_t retries = 0;  // SDO transfers repeated after a timeout
  bool stored = false;
  bool started = false;            // NMT start sent
  bool guarding_fallback = false;  // heartbeat refused, node guarding configured instead
  std::uint8_t changed_groups = 0; // StoreGroup bits of the values changed
  canopen::Duration duration{};
  std::vector<PlanStepTiming> steps;
  // Values found different from the plan before writing them, in words
  // ("0x1017 read 0x00002355, configured 0x00000064"); at most kMaxDiffered.
  std::vector<std::string> differed;
  static constexpr std::size_t kMaxDiffered = 8;

  [[nodiscard]] bool ok() const noexcept { return error.ok(); }
};

struct PlanRunnerOptions {
  std::uint8_t sdo_retries = 2;  // config::Bus::sdo_retries
  bool start_node = true;        // send NMT start at the end of the plan
  // When the sink refuses a frame, try again this soon (counts as a retry).
  canopen::Duration tx_retry = std::chrono::milliseconds{10};
};

class PlanRunner {
 public:
  // `sink` is the bus the SDO client sends on (NMT frames go there too). The
  // plan is copied; `sdo` must outlive the runner and is re-addressed to the
  // plan's node-ID at start().
  PlanRunner(can::FrameSink& sink, canopen::SdoClient& sdo, ConfigPlan plan, PlanRunnerOptions options = {});
  // A runner dropped mid-transfer (the device rebooted, the interface went
  // down, the gateway stops) releases the SDO client it borrowed, so the
  // device's next plan can start at once.
  ~PlanRunner();
  PlanRunner(const PlanRunner&) = delete;
  PlanRunner& operator=(const PlanRunner&) = delete;

  // Begins the run; an error (code sdo_busy, or the SDO client's refusal of
  // the node-ID) means nothing was sent.
  [[nodiscard]] Error start(canopen::TimePoint now);
  // Feeds a received frame; true when it was the SDO client's.
  bool on_frame(const can::Frame& frame, canopen::TimePoint now) noexcept;
  // Timeouts, retries; returns the next deadline (kNever when finished).
  canopen::TimePoint process(canopen::TimePoint now) noexcept;

  [[nodiscard]] bool running() const noexcept { return phase_ != Phase::kIdle && phase_ != Phase::kDone; }
  [[nodiscard]] bool finished() const noexcept { return phase_ == Phase::kDone; }
  [[nodiscard]] const PlanRunResult& result() const noexcept { return result_; }
  [[nodiscard]] const ConfigPlan& plan() const noexcept { return plan_; }

 private:
  enum class Phase : std::uint8_t {
    kIdle,
    kNmt,            // an NMT frame waits to be queued
    kWriteRead,      // reading the current value
    kWriteDownload,  // writing
    kWriteVerify,    // reading back
    kMapReadCob,
    kMapReadCount,
    kMapReadEntry,
    kMapDownload,    // the remap sub-steps, ops_[op_pos_]
    kMapVerifyCount,
    kMapVerifyEntry,
    kMapVerifyCob,
    kStore,
    kDone,
  };
  struct Transfer {
    bool upload = true;
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    std::uint32_t value = 0;
    std::uint8_t size = 4;
  };

  void begin_step(canopen::TimePoint now);
  void end_step(canopen::TimePoint now);
  void begin_write(canopen::TimePoint now);
  void next_write(canopen::TimePoint now);
  void begin_remap(canopen::TimePoint now);
  void next_store(canopen::TimePoint now);
  void send_nmt(canopen::TimePoint now);

  void upload(std::uint16_t index, std::uint8_t sub, canopen::TimePoint now);
  void download(std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size, canopen::TimePoint now);
  void launch(canopen::TimePoint now);
  void drain(canopen::TimePoint now);
  void on_result(const canopen::SdoClient::Result& r, canopen::TimePoint now);
  void on_success(std::uint32_t value, canopen::TimePoint now);
  void on_write_answer(std::uint32_t value, canopen::TimePoint now);
  void on_mapping_read(std::uint32_t value, canopen::TimePoint now);
  void plan_mapping_writes(const PlanStep& s);
  void on_mapping_written(canopen::TimePoint now);
  void on_mapping_verify(std::uint32_t value, canopen::TimePoint now);
  void on_failure(const canopen::SdoClient::Result& r, canopen::TimePoint now);

  void fail(PlanRunErrc code, std::string message, canopen::TimePoint now, std::error_code sdo = {});
  void finish(canopen::TimePoint now);
  [[nodiscard]] std::string where() const;  // "device 'lift': <step label>: "

  can::FrameSink& sink_;
  canopen::SdoClient& sdo_;
  ConfigPlan plan_;
  PlanRunnerOptions options_;

  Phase phase_ = Phase::kIdle;
  PlanRunResult result_;
  canopen::TimePoint started_at_{};
  canopen::TimePoint step_started_at_{};
  std::uint32_t step_writes_ = 0;
  std::size_t step_ = 0;

  Transfer transfer_;
  std::uint8_t retries_left_ = 0;
  canopen::TimePoint retry_at_ = canopen::kNever;  // relaunch a refused frame / NMT

  // kind write: the writes of the step (primary, or the fallback)
  std::span<const SdoWrite> writes_;
  std::size_t write_pos_ = 0;
  bool on_fallback_ = false;
  bool verify_now_ = true;     // read the current write back (off for write-only objects)
  std::uint32_t written_ = 0;  // value sent by the current write

  // kind tpdo_mapping
  std::uint32_t cob_id_ = 0;
  std::size_t entry_pos_ = 0;
  bool mapping_differs_ = false;
  std::vector<Transfer> ops_;
  std::size_t op_pos_ = 0;

  // kind store
  std::size_t store_pos_ = 0;
};

}  // namespace cobridge::bus

template <>
struct std::is_error_code_enum<cobridge::bus::PlanRunErrc> : std::true_type {};
