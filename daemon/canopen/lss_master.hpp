// LssMaster: the gateway side of CiA 305 LSS, as non-blocking state machines.
//
// One operation at a time. Starting one sends its first frame(s) and returns
// at once; the caller then feeds every 0x7E4 frame to `on_frame(frame, now)`
// and calls `process(now)` at the deadline it returns. When the operation
// ends its outcome is collected with `take_result()`. Operations without an
// answer (switch state global, activate bit timing) complete synchronously.
//
// An answer is in time when its kernel receive stamp is within the step's
// wait of the request, whenever the caller hands it over (a control thread
// held up by an fsync or the scheduler does not make answers late); the
// caller hands over what it has received before calling `process`.
// "No answer" is only visible as a timeout. The first step of a search
// ("is anybody there?") waits `Config::timeout`; later search steps wait what
// the bus taught (AnswerTiming, between `min_timeout` and `timeout`), and an
// answered step ends once the other slaves' answers have had time to come.
// A Fastscan whose field confirmation fails (a bit decided on a late answer,
// or the confirm's own answer late) sends switch state global waiting (a
// slave that took the serial's confirm is in configuration state, deaf to
// Fastscan) and begins again from its reset with longer waits, twice at
// most; so does a Slowscan whose final switch selective is unanswered.
// A found identity is a verified identity: a Fastscan answer
// (0x4F) says nothing of the step it answers, so a late answer taken for a
// later step's can decide a bit, and even a confirm, wrongly: once (UML, 32
// slaves) an identity that exists nowhere came out. Before its result is
// given, the Fastscan sends switch state global waiting and a switch state
// selective to the identity found: only that slave answers (0x44, which no
// other step's answer can be taken for) and re-enters configuration state.
// Unanswered within the timeout, the scan begins again (as above); with no
// restart left, kFastscanUnconfirmed. Cost of an unguided Fastscan:
// 1 probe + 4 x (32 bits + 1 confirm) + 1 verify = 134 exchanges per device,
// one silent per 1-bit of the address; a FastscanPlan confirms known fields
// whole.
// Slowscan: at most 65 identify steps of 6 frames each, plus switch selective.
// Thread: the one thread that owns the LSS channel (bus manager); never
// blocks, does not allocate per frame; one clock read per step sent.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <system_error>
#include <type_traits>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/answer_timing.hpp"
#include "canopen/clock.hpp"
#include "canopen/fastscan_plan.hpp"
#include "canopen/lss.hpp"

namespace cobridge::canopen {

// Errors of the master itself; category "lss".
enum class LssErrc : int {
  kBusy = 1,              // another operation is running
  kSendFailed = 2,        // the sink refused a frame; the operation was abandoned
  kInvalidArgument = 3,   // e.g. an inquire specifier that is not 0x5A..0x5E
  kTimeout = 4,           // a confirmed service got no answer within the timeout
  kNotFound = 5,          // Fastscan/Slowscan: no (unconfigured / matching) slave answered
  kFastscanLost = 6,      // a Fastscan field confirm got no answer (slave left mid-scan)
  kFastscanUnconfirmed = 7,  // nobody answered the switch selective to the identity a Fastscan found
};

[[nodiscard]] const std::error_category& lss_category() noexcept;
[[nodiscard]] std::error_code make_error_code(LssErrc e) noexcept;

// Errors a slave reports in byte 1 of 0x11/0x13/0x17; category "lss_slave".
// The value is (cs << 8) | code, so the message can name the service's
// meaning ("configure node-ID: node-ID out of range").
[[nodiscard]] const std::error_category& lss_slave_error_category() noexcept;
[[nodiscard]] std::error_code make_lss_slave_error(LssCs service, uint8_t code) noexcept;

enum class LssOperation : uint8_t {
  kNone,
  kSwitchSelective,
  kConfigureNodeId,
  kConfigureBitTiming,
  kStoreConfiguration,
  kInquire,
  kIdentifyRemoteSlave,
  kIdentifyNonConfigured,
  kFastscan,
  kSlowscan,
};

struct LssMasterConfig {
  // How long to wait for an answer to a confirmed service, and the longest a
  // search step waits for one (the bus's lss_timeout_ms).
  Duration timeout = std::chrono::milliseconds(100);
  // The shortest a search step without answer may wait once answer times
  // have been measured (AnswerTiming); zero or >= timeout: every search step
  // waits the full timeout and nothing is learnt.
  Duration min_timeout{};
  // The clock of the answers' kernel receive stamps (can::Frame::timestamp_ns).
  // An answer is judged by its stamp against the step's send: one that came
  // within the wait counts even when the control thread got to it late
  // (a descheduled thread, a slow fsync). Frames without a stamp (0) are
  // judged by the time they are handed over. Tests set a clock of their own.
  int64_t (*stamp_clock_ns)() noexcept = &can::frame_clock_ns;
};

class LssMaster {
 public:
  using Config = LssMasterConfig;

  // Identity fields the caller already knows; Fastscan confirms such a field
  // in one step instead of searching its 32 bits.
  struct FastscanKnown {
    std::optional<uint32_t> vendor;
    std::optional<uint32_t> product;
    std::optional<uint32_t> revision;
    std::optional<uint32_t> serial;

    // One target; the unknown fields are searched.
    [[nodiscard]] FastscanPlan to_plan() const noexcept;
  };

  struct Result {
    LssOperation operation = LssOperation::kNone;
    std::error_code error;
    LssAddress address;        // switch selective, Fastscan, Slowscan
    uint32_t value = 0;        // inquire (node-ID in the low byte)
    bool answered = false;     // identify: at least one slave answered
    uint32_t answers = 0;      // answers seen; identical frames may merge on a bus, so a lower bound
    uint8_t slave_error = 0;   // byte 1 of a 0x11/0x13/0x17 answer
    uint8_t slave_spec_error = 0;  // byte 2 (meaningful when slave_error == 0xFF)
    uint32_t frames_sent = 0;  // cost accounting
    uint32_t steps = 0;        // request/answer exchanges (each waits for answers)
    uint32_t silent_steps = 0; // exchanges that ended without an answer (each cost a timeout)
    uint32_t restarts = 0;     // Fastscan / Slowscan begun again, carefully, after a step decided on a late answer
    Duration elapsed{};        // from start to the end of the operation
  };

  explicit LssMaster(can::FrameSink& sink, Config config = Config{}) noexcept;

  // --- operations without an answer (complete immediately) ---
  // CiA 305 switch state global; J§1.5 `04 01` (configuration), `04 00` (waiting).
  std::error_code switch_state_global(LssMode mode) noexcept;
  // CiA 305 activate bit timing 0x15 with the switch delay in ms.
  std::error_code activate_bit_timing(uint16_t switch_delay_ms) noexcept;

  // --- operations with a result from take_result() ---
  // J§1.5 / E§6 switch mode selective: 0x40..0x43, waits for 0x44.
  std::error_code switch_state_selective(const LssAddress& address, TimePoint now) noexcept;
  // J§1.5.1 configure node-ID 0x11 (1..127, or FFh). Slave errors in the result.
  std::error_code configure_node_id(uint8_t node_id, TimePoint now) noexcept;
  // E§6.2 / CiA 305 configure bit timing 0x13: `13 selector index`.
  std::error_code configure_bit_timing(uint8_t table_index, TimePoint now,
                                       uint8_t table_selector = kLssBitTimingTableStandard) noexcept;
  // J§1.5.3 store configuration 0x17.
  std::error_code store_configuration(TimePoint now) noexcept;
  // CiA 305 inquire 0x5A..0x5E; the value is in Result::value.
  std::error_code inquire(LssCs what, TimePoint now) noexcept;
  // CiA 305 identify remote slave 0x46..0x4B; waits one full timeout.
  std::error_code identify_remote_slave(const LssRange& range, TimePoint now) noexcept;
  // CiA 305 identify non-configured remote slave 0x4C; waits one full timeout.
  std::error_code identify_non_configured(TimePoint now) noexcept;
  // CiA 305 Fastscan. On success Result::address is the slave found (the
  // smallest unconfigured address) and that slave is in configuration state.
  std::error_code fastscan(TimePoint now, const FastscanKnown& known = FastscanKnown{}) noexcept;
  // Fastscan guided by what is known (FastscanPlan): candidate values are
  // confirmed whole, most shared first; a field is searched bit by bit only
  // when the plan allows it. Result kNotFound when no slave matches the plan.
  std::error_code fastscan(TimePoint now, const FastscanPlan& plan) noexcept;
  // Slowscan: binary search with identify remote slave over `bounds` (vendor
  // and product exact), first revision then serial, for the smallest address
  // in it; then switch selective to it. For devices without Fastscan. To find
  // the next device, search again above the one found (identify does not
  // exclude configured slaves).
  std::error_code slowscan(const LssRange& bounds, TimePoint now) noexcept;

  // Abandons the running operation without a result.
  void cancel() noexcept;

  // Feed every received frame. Returns true when it was an LSS answer (0x7E4).
  bool on_frame(const can::Frame& frame, TimePoint now) noexcept;
  // Drives timeouts and search steps; returns the next deadline or kNever.
  TimePoint process(TimePoint now) noexcept;

  [[nodiscard]] bool busy() const noexcept { return phase_ != Phase::kIdle; }
  // The result of the last finished operation, once. A new operation discards
  // an untaken result.
  [[nodiscard]] std::optional<Result> take_result() noexcept;

  [[nodiscard]] const Config& config() const noexcept { return config_; }
  // What was learnt about this bus's answer times (kept across operations).
  [[nodiscard]] const AnswerTiming& timing() const noexcept { return timing_; }

 private:
  enum class Phase : uint8_t {
    kIdle,
    kAwaitReply,      // a confirmed service: the first answer with expect_ ends it
    kCollect,         // identify: count answers until the deadline
    kFastscanProbe,
    kFastscanBit,
    kFastscanConfirm,
    kFastscanVerify,  // switch selective to the identity found: answered only by that slave
    kSlowscanProbe,
    kSlowscanRevision,
    kSlowscanSerial,
  };

  std::error_code begin(LssOperation op, TimePoint now) noexcept;
  bool send(const can::Frame& f) noexcept;
  bool send_lss(LssCs cs, uint32_t value = 0, uint8_t b5 = 0, uint8_t b6 = 0, uint8_t b7 = 0) noexcept;
  bool send_identify(const LssRange& range) noexcept;
  bool send_switch_selective(const LssAddress& a) noexcept;
  void arm(Phase phase, LssCs expect, TimePoint now) noexcept;
  [[nodiscard]] TimePoint answered_at(const can::Frame& f, TimePoint now) const noexcept;
  void finish(std::error_code ec, TimePoint now) noexcept;
  void on_step_done(TimePoint now) noexcept;
  [[nodiscard]] bool fastscan_probe(TimePoint now) noexcept;
  [[nodiscard]] bool slowscan_probe(TimePoint now) noexcept;
  void on_reply_missing(TimePoint now) noexcept;
  [[nodiscard]] bool begin_again() noexcept;
  void fastscan_field(uint8_t field, TimePoint now) noexcept;
  void fastscan_next_guess(TimePoint now) noexcept;
  void fastscan_not_found(TimePoint now) noexcept;
  void fastscan_search(TimePoint now) noexcept;
  void fastscan_confirm_done(TimePoint now) noexcept;
  void fastscan_bit_step(TimePoint now) noexcept;
  void fastscan_confirm(TimePoint now) noexcept;
  void fastscan_verify(TimePoint now) noexcept;
  void fastscan_unverified(TimePoint now) noexcept;
  void slowscan_step(TimePoint now) noexcept;
  [[nodiscard]] bool search_phase() const noexcept;
  [[nodiscard]] Duration search_wait() const noexcept;

  can::FrameSink& sink_;
  Config config_;
  AnswerTiming timing_;
  TimePoint step_sent_{};
  int64_t step_sent_stamp_ns_ = 0;  // step_sent_ on stamp_clock_ns (0: none)
  bool careful_ = false;  // a scan begun again: longer waits for silence and for other slaves' answers
  Phase phase_ = Phase::kIdle;
  LssCs expect_ = LssCs::kSwitchSelectiveResponse;
  TimePoint deadline_ = kNever;
  TimePoint started_{};
  Result current_;
  std::optional<Result> result_;
  bool answered_ = false;
  // Fastscan
  FastscanPlan plan_;
  FastscanPlan::Tried fs_tried_ = 0;
  bool fs_guess_ = false;  // the confirm running is a guess from the plan, not a searched value
  uint8_t fs_field_ = 0;
  uint8_t fs_bit_ = 0;
  // Slowscan: [lo, hi] of the field being searched, and the midpoint probed
  LssRange ss_range_;
  LssRange ss_bounds_;  // the whole Slowscan's, for a restart
  uint32_t ss_lo_ = 0;
  uint32_t ss_hi_ = 0;
  uint32_t ss_mid_ = 0;
};

}  // namespace cobridge::canopen

template <>
struct std::is_error_code_enum<cobridge::canopen::LssErrc> : std::true_type {};
