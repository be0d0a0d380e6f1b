// LssSlave: the device side of CiA 305 LSS, as the encoder simulator and the
// unit tests use it.
//
// Holds the LSS state (waiting/configuration), the active and pending node-ID
// and bit timing, and answers master requests on 0x7E5 with frames on 0x7E4.
// `Features` selects which services exist, because the families differ: the
// rotary series (J) claims DSP-305 V1.1.2, which predates Fastscan, while the
// multiturn series (E) claims V3.0.0. Configured values become active only
// when the owner calls `activate_pending()` (NMT reset communication or power
// up: CiA 305 makes a configured node-ID active only then); the slave never
// resets itself.
// Thread: the single thread that drives the simulated device; `on_frame` does
// not allocate and never blocks (the store handler must not block either).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <utility>

#include "can/frame_sink.hpp"
#include "canopen/lss.hpp"

namespace cobridge::canopen {

// Which optional LSS services a slave implements (LssSlave::Features).
struct LssSlaveFeatures {
  bool fastscan = true;    // 0x51 (CiA 305 V2.2 and later)
  bool inquire = true;     // 0x5A..0x5E
  bool identify = true;    // 0x46..0x4B and 0x4C
  bool bit_timing = true;  // 0x13 and 0x15; when false 0x13 answers "not supported"
  bool store = true;       // 0x17; when false it answers "not supported"
  uint16_t bit_timings = kLssBitTimingsNovotechnik;  // supported standard-table indices
  // Also read J§1.5.2's printed form `13 IDX 00` (index in byte 1). Only
  // taken when byte 2 is 0 and byte 1 is a supported index; `13 00 00` means
  // 1000 kbit/s in both forms, so the two never disagree.
  bool accept_j_bit_timing_form = false;
  // Configure node-ID (0x11): a foreign or misbehaving slave may refuse
  // every node-ID (answers error 1, "out of range") or not answer at all.
  enum class NodeIdAssignment : uint8_t { accept, refuse, ignore };
  NodeIdAssignment node_id_assignment = NodeIdAssignment::accept;
  // The first so many configure node-ID requests go unanswered (lost on the
  // wire, a busy slave), then as node_id_assignment says.
  uint8_t lose_node_id_requests = 0;

  // Rotary series, J§1.5 (DSP-305 V1.1.2): no Fastscan (added in V2.2) and
  // no inquire. J documents no identify service either; it is kept on
  // because identify remote slave predates Fastscan and Slowscan relies on it.
  [[nodiscard]] static constexpr LssSlaveFeatures rotary_j() noexcept {
    LssSlaveFeatures f;
    f.fastscan = false;
    f.inquire = false;
    f.accept_j_bit_timing_form = true;
    return f;
  }
  // Multiturn series, E§6 (DS-305 V3.0.0): every service.
  [[nodiscard]] static constexpr LssSlaveFeatures multiturn_e() noexcept { return LssSlaveFeatures{}; }
};

class LssSlave {
 public:
  using Features = LssSlaveFeatures;

  // Called on store configuration (0x17) when `store` is supported; returns
  // the error code to answer. It may read pending_node_id()/pending_bit_timing().
  using StoreHandler = std::function<LssStoreError(const LssSlave&)>;

  LssSlave(can::FrameSink& sink, const LssAddress& identity, uint8_t active_node_id,
           Features features = Features{}) noexcept;

  // Handles one frame. Returns true when it was an LSS request this slave
  // acted on (whether or not it answered).
  bool on_frame(const can::Frame& frame) noexcept;

  [[nodiscard]] LssMode mode() const noexcept { return mode_; }
  [[nodiscard]] const LssAddress& identity() const noexcept { return identity_; }
  [[nodiscard]] const Features& features() const noexcept { return features_; }
  [[nodiscard]] uint8_t active_node_id() const noexcept { return active_node_id_; }
  [[nodiscard]] uint8_t pending_node_id() const noexcept { return pending_node_id_; }
  // Fastscan and identify non-configured answer only while this is true: both
  // the active and the pending node-ID are FFh (CiA 305: only non-configured
  // slaves take part), so a slave stops answering as soon as it is configured.
  [[nodiscard]] bool unconfigured() const noexcept;

  [[nodiscard]] std::optional<uint8_t> active_bit_timing() const noexcept { return active_bit_timing_; }
  [[nodiscard]] std::optional<uint8_t> pending_bit_timing() const noexcept { return pending_bit_timing_; }

  // What reset communication / power up does to LSS: pending values become
  // active and the slave returns to waiting state.
  void activate_pending() noexcept;

  void set_store_handler(StoreHandler handler) { store_handler_ = std::move(handler); }
  // The values the last successful store configuration wrote.
  [[nodiscard]] std::optional<uint8_t> stored_node_id() const noexcept { return stored_node_id_; }
  [[nodiscard]] std::optional<uint8_t> stored_bit_timing() const noexcept { return stored_bit_timing_; }

  // J§1.5 / E§6: "LSS can only be used when the encoder is in the stopped or
  // pre-operational state". The owner sets this while NMT-operational.
  void set_ignore(bool ignore) noexcept { ignore_ = ignore; }
  [[nodiscard]] bool ignoring() const noexcept { return ignore_; }

  // Set by activate bit timing (0x15): the switch delay in ms. The owner
  // applies the new rate (after the delay); the pending index is already active.
  [[nodiscard]] std::optional<uint16_t> take_bit_timing_activation() noexcept;

  // CiA 305 V3: a slave without an active node-ID that leaves configuration
  // state with a valid pending node-ID performs reset communication on its own.
  // The owner polls this and then calls activate_pending() and sends boot-up.
  [[nodiscard]] bool take_reset_communication_request() noexcept;

  // Answers the sink refused (a real device would lose them too).
  [[nodiscard]] uint32_t tx_failures() const noexcept { return tx_failures_; }

 private:
  bool on_configure_node_id(const can::Frame& f) noexcept;
  bool on_activate_bit_timing(const can::Frame& f) noexcept;
  void reply(LssCs cs, uint32_t value = 0) noexcept;
  void reply_error(LssCs cs, uint8_t error) noexcept;
  void on_switch_global(const can::Frame& f) noexcept;
  bool on_switch_selective(LssCs cs, uint32_t value) noexcept;
  bool on_identify(LssCs cs, uint32_t value) noexcept;
  bool on_fastscan(const can::Frame& f) noexcept;
  bool on_bit_timing(const can::Frame& f) noexcept;
  bool on_store() noexcept;
  bool on_inquire(LssCs cs) noexcept;

  can::FrameSink& sink_;
  LssAddress identity_;
  Features features_;
  StoreHandler store_handler_;
  LssMode mode_ = LssMode::kWaiting;
  uint8_t active_node_id_;
  uint8_t pending_node_id_;
  std::optional<uint8_t> active_bit_timing_;
  std::optional<uint8_t> pending_bit_timing_;
  std::optional<uint8_t> stored_node_id_;
  std::optional<uint8_t> stored_bit_timing_;
  std::optional<uint16_t> activation_delay_ms_;
  uint8_t selective_next_ = 0;  // how many of 0x40..0x43 matched in a row
  uint8_t identify_next_ = 0;   // how many of 0x46..0x4B matched in a row
  uint8_t fastscan_sub_ = 0;    // LSSSub this slave compares next
  bool ignore_ = false;
  bool reset_requested_ = false;
  uint32_t tx_failures_ = 0;
  uint8_t node_id_requests_lost_ = 0;  // of features_.lose_node_id_requests
};

}  // namespace cobridge::canopen
