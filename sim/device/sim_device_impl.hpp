// SimDevice::Impl: the state of one simulated encoder, shared by the
// concept files of this folder (private header).
//
// The CANopen runtime all families share is one file per concept:
// sim_device.cpp (facade, transmit path), od_setup.cpp (object dictionary),
// node_addressing.cpp (node-ID, bit rate, LSS), store_commands.cpp
// (save/load/kill), encoder_settings.cpp (encoder set-up, measuring cycle),
// sdo_hooks.cpp (shared write rules), power_and_reset.cpp (power, boot, NMT
// resets), error_control.cpp (NMT states, heartbeat, guarding, status),
// tpdo_runtime.cpp (TPDOs), frame_input.cpp (received frames, timers),
// can_controller.cpp (bus errors). What differs by family is a value of
// `traits` (families/traits.hpp) or a hook of family_dispatch.cpp, which
// switches to family_rotary.cpp / family_multiturn.cpp / family_ifm.cpp
// (OD quirks and write rules, fault EMCYs and status bits).
// Thread: the simulator's bus thread; nothing here is thread-safe.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "canopen/lss_slave.hpp"
#include "canopen/node_guard.hpp"
#include "canopen/object_dictionary.hpp"
#include "canopen/pdo_map.hpp"
#include "canopen/sdo_server.hpp"
#include "device/emcy_producer.hpp"
#include "device/encoder_front_end.hpp"
#include "device/late_answers.hpp"
#include "device/nv_store.hpp"
#include "device/sim_device.hpp"
#include "device/tpdo.hpp"
#include "encoder/condition_monitor.hpp"
#include "families/family_traits.hpp"

namespace cobridge::sim {

namespace cob = canopen::cob;
using canopen::NmtState;

// Objects the shared runtime reads or writes (CiA 301 §7.5.2).
namespace device_objects {
inline constexpr std::uint16_t kStatusRegister = 0x1002;
inline constexpr std::uint16_t kCobIdSync = 0x1005;
inline constexpr std::uint16_t kGuardTime = 0x100C;
inline constexpr std::uint16_t kLifeTimeFactor = 0x100D;
inline constexpr std::uint16_t kStore = 0x1010;
inline constexpr std::uint16_t kRestore = 0x1011;
inline constexpr std::uint16_t kHeartbeatTime = 0x1017;
inline constexpr std::uint16_t kIdentity = 0x1018;
inline constexpr std::uint16_t kTpdoComm = 0x1800;
inline constexpr std::uint16_t kTpdoMap = 0x1A00;
inline constexpr std::uint16_t kNmtStartup = 0x1F80;
inline constexpr std::uint32_t kAutostartBit = 0x08;  // J§1.3.1, E§4.1: bit 3, not CiA 302's bit 2
inline constexpr std::chrono::milliseconds kMeasuringCycle{1};  // J§1.2.5, E§3.3
}  // namespace device_objects

// The fault confinement state of the device's CAN controller (CiA 301 / ISO
// 11898-1), as the simulator's error frames set it (can_controller.cpp).
enum class CanControllerState : std::uint8_t { error_active, error_passive, bus_off };

// Bits of Impl::faults, one per FaultKind (clear excluded).
[[nodiscard]] constexpr std::uint32_t fault_bit(FaultKind k) noexcept { return 1U << static_cast<unsigned>(k); }

struct SimDevice::Impl {
  Impl(DeviceSpec spec_in, const device::DeviceDescription& description, can::FrameSink& sink,
       std::filesystem::path state_dir);

  // The transmit path SdoServer and LssSlave are given: stamps truth records.
  struct Tx final : can::FrameSink {
    Impl* device = nullptr;
    [[nodiscard]] bool send(const can::Frame& frame) noexcept override;
  };

  // ---- fixed at construction ------------------------------------------
  DeviceSpec spec;
  const ModelInfo& model;
  FamilyId family;
  const families::FamilyTraits& traits;  // what differs by family (families/traits.hpp)
  const device::DeviceDescription& desc;
  can::FrameSink& bus;
  std::filesystem::path nv_file;
  NvStore nv;
  TruthSink truth;
  Tx tx;
  std::uint8_t channels = 1;
  std::uint8_t factory_node = 127;
  std::uint32_t revision = 0;  // 0x1018/3
  std::uint16_t factory_kbit = 250;

  // ---- runtime ----------------------------------------------------------
  bool powered = false;
  bool silent = false;
  std::uint32_t reboot_on_sdo = 0;  // see SimDevice::reboot_on_sdo
  std::uint16_t abort_sdo_index = 0;  // see SimDevice::abort_sdo (0: none)
  std::uint32_t abort_sdo_code = 0;
  std::uint16_t ignore_sdo_index = 0;  // see SimDevice::ignore_sdo (0: none)
  std::uint32_t ignore_sdo_left = 0;
  std::uint32_t ignore_nmt_starts = 0;  // see SimDevice::ignore_nmt_start
  NvContents nv_data;
  std::unique_ptr<canopen::ObjectDictionary> od;
  std::unique_ptr<canopen::SdoServer> sdo;
  std::optional<canopen::LssSlave> lss;
  canopen::NmtSlaveState nmt;
  canopen::GuardResponder guard;
  EmcyProducer emcy;
  EncoderFrontEnd encoder;
  ConditionMonitor condition;          // multiturn only (E§4.3, E§5.8)
  TimePoint last_condition_update{};
  std::uint32_t persisted_time_total = 0;
  std::array<Tpdo, 2> tpdo{};
  std::array<canopen::PdoLayout, 2> layout{};
  std::array<bool, 2> layout_ok{};
  std::array<bool, 2> tpdo_present{};
  std::array<bool, 2> sampled_valid{};
  std::array<can::Frame, 2> sampled{};  // type 252: data taken at the SYNC

  std::uint8_t active_node = 127;
  std::uint8_t pending_node = 127;
  std::uint16_t active_kbit = 250;
  std::uint16_t pending_kbit = 250;

  TimePoint next_heartbeat = canopen::kNever;
  TimePoint next_measure = canopen::kNever;
  TimePoint now_cache{};
  LateAnswers late_lss;                // spec.late_lss: LSS answers held back
  bool reset_node_requested = false;   // ifm 0x2300: after the SDO confirmation
  bool ifm_defaults_pending = false;   // ifm 'load' (F§6.3.5)
  bool first_measure = true;
  bool life_guarding_lost = false;
  bool legacy_kill = false;            // RSX/RFX 'kill' resets node-ID / bit rate too (J§1.10)
  CanControllerState can_state = CanControllerState::error_active;

  std::uint32_t faults = 0;            // fault_bit() of active faults
  bool over_range_latched = false;     // E: until 0x2100 (E§4.3)
  bool under_range_latched = false;
  std::array<ChannelSample, 2> last{};
  std::uint16_t alarms = 0;            // 0x6503
  std::uint16_t warnings = 0;          // 0x6505
  std::uint32_t status = 0;            // 0x1002 (without the NMT bits)

  // Values the EDS leaves open ("see label", "e.g."), by NvImage::key.
  std::map<std::uint32_t, std::uint64_t> factory;

  // ---- shared runtime (the concept files above) --------------------------
  Error power_on(TimePoint now);
  void power_off() noexcept;
  // TPDO policy, faults, status, guarding and controller state as after power-up.
  void clear_runtime_state();
  void boot(TimePoint now);
  void reset_node(TimePoint now);
  void reset_communication(TimePoint now);  // the communication area from the stored image
  void reset_communication(TimePoint now, const NvImage* image);  // ... from `image` (null = defaults)
  void on_frame(const can::Frame& frame, TimePoint now);
  void on_nmt_frame(const can::Frame& frame, TimePoint now);  // a node it addresses, configured
  void on_lss_frame(const can::Frame& frame, TimePoint now);
  void on_sync(TimePoint now);                                   // a valid SYNC NMT allows
  void on_rtr_frame(const can::Frame& frame, TimePoint now);     // node guarding or a TPDO request
  TimePoint process(TimePoint now);
  void inject(FaultKind fault, TimePoint now);

  // ---- can_controller.cpp: reactions to the bus state -------------------
  // A Linux CAN error frame (<linux/can/error.h>) the simulator delivered.
  void on_error_frame(const can::Frame& frame, TimePoint now);
  void enter_error_passive();
  void leave_error_passive();
  void enter_bus_off();
  void recover_from_bus_off();
  // The 0x1002 bits of the controller state (J§1.9.1 bits 4/3/2, E§10.1
  // bits 16/17/18; ifm has no 0x1002).
  [[nodiscard]] std::uint32_t can_status_bits() const noexcept;
  // EMCY 0x8120 / 0x8140 as the family's table prints them.
  void send_can_emcy(std::uint16_t code);

  bool send(const can::Frame& frame, TruthRecord::Kind kind, std::uint8_t pdo = 0) noexcept;
  // True when `frame` was an SDO request abort_sdo() or ignore_sdo() waits
  // for (now aborted, or left unanswered).
  bool sdo_fault_injected(const can::Frame& frame) noexcept;
  static bool emcy_thunk(void* context, const can::Frame& frame) noexcept;
  void emit_truth(const can::Frame& frame, TruthRecord::Kind kind, std::uint8_t pdo) const;
  void send_tpdo(std::size_t i, TimePoint now);
  void fill_tpdo(std::size_t i, can::Frame& frame) const noexcept;
  void on_nmt_change(canopen::NmtState from, TimePoint now);
  void sync_lss_pending();
  void measure(TimePoint now);
  void configure_encoder();
  // The preset offsets kept in non-volatile memory beside the preset (NV-only
  // keys 0x6509 sub 0x80 + channel), or 0 when `image` is null.
  void restore_offsets(const NvImage* image);
  static constexpr std::uint16_t kOffsetKeyIndex = 0x6509;
  static constexpr std::uint8_t kOffsetKeySub = 0x80;
  void reconfigure_tpdo(std::size_t i, TimePoint now);
  void configure_guard();
  void restart_heartbeat(TimePoint now);
  void refresh_status() noexcept;
  void send_emcy(const canopen::Emcy& e, families::EmcyLevel level) noexcept;

  Error build_od();
  void install_hooks();
  [[nodiscard]] std::uint64_t factory_value(const device::ObjectDesc& e, std::uint8_t node) const noexcept;
  // Writes factory values (overlaid with `image` where it has a value) to the
  // writable entries `select` picks.
  using EntrySelect = std::function<bool(const device::ObjectDesc&)>;
  void load_parameters(const EntrySelect& select, const NvImage* image);
  [[nodiscard]] std::uint32_t save(std::uint8_t store_sub);
  [[nodiscard]] std::uint32_t load(std::uint8_t store_sub);
  [[nodiscard]] std::uint32_t kill(std::uint8_t store_sub);
  [[nodiscard]] Error persist() const;

  std::uint32_t on_read(std::uint16_t index, std::uint8_t sub);
  std::uint32_t on_write(const canopen::WriteRequest& req);
  void after_write(std::uint16_t index, std::uint8_t sub);
  std::uint32_t check_tpdo_write(const canopen::WriteRequest& req);
  std::uint32_t check_mapping_write(const canopen::WriteRequest& req);

  // Node-ID / bit rate as the family's objects hold them.
  [[nodiscard]] std::uint8_t node_from_od() const noexcept;
  [[nodiscard]] std::uint16_t kbit_from_od() const noexcept;
  void node_to_od(std::uint8_t node) noexcept;
  void kbit_to_od(std::uint16_t kbit) noexcept;
  // The family's node-ID or bit-rate object (J§1.3.3, E§4.3 0x2000/0x2001; F§7.4 0x3000/0x3001).
  [[nodiscard]] bool is_address_object(std::uint16_t index) const noexcept {
    const auto& a = family_facts(family).addressing;
    return index == a.node_id_index || index == a.bitrate_index;
  }

  [[nodiscard]] bool scaling_active() const noexcept;
  [[nodiscard]] canopen::LssAddress identity_of() const noexcept;
  canopen::LssStoreError lss_store(const canopen::LssSlave& slave);
  // Any integer entry, sign-extended by its type (0 when missing).
  [[nodiscard]] std::int64_t get_int(std::uint16_t index, std::uint8_t sub) const noexcept;
  [[nodiscard]] bool pre_operational() const noexcept {
    return nmt.state() == canopen::NmtState::pre_operational;
  }

  // ---- family files ------------------------------------------------------
  void family_factory();                                 // fill `factory`
  void family_adjust(canopen::EntryDef& def) const;      // before insert
  void family_extras();                                  // entries the EDS lacks
  void family_after_load() noexcept;                     // after parameters were (re)loaded
  std::uint32_t family_on_write(const canopen::WriteRequest& req);
  void family_after_write(std::uint16_t index, std::uint8_t sub);
  // Writes the sample to the family's objects; may change `s` (error values,
  // held CAM states) so the caller remembers what was published.
  void family_publish(std::size_t ch, ChannelSample& s, const ChannelSample& before, bool first);
  void family_fault(FaultKind fault, TimePoint now);
  void family_life_guarding(bool lost);
  void family_status() noexcept;  // 0x1002 / 0x6503 / 0x6505 from the fault state

  void rotary_factory();
  void rotary_adjust(canopen::EntryDef& def) const;
  std::uint32_t rotary_on_write(const canopen::WriteRequest& req);
  void rotary_after_write(std::uint16_t index, std::uint8_t sub);
  void rotary_publish(std::size_t ch, ChannelSample& s, const ChannelSample& before, bool first);
  void rotary_fault(FaultKind fault, TimePoint now);
  void rotary_status() noexcept;

  void multiturn_factory();
  void multiturn_extras();
  std::uint32_t multiturn_on_write(const canopen::WriteRequest& req);
  void multiturn_after_write(std::uint16_t index, std::uint8_t sub);
  void multiturn_publish(ChannelSample& s, const ChannelSample& before, bool first);
  void multiturn_fault(FaultKind fault, TimePoint now);
  void multiturn_life_guarding(bool lost);
  void multiturn_status() noexcept;
  // Condition monitoring (E§4.3 0x2002/0x2003/0x23xx, E§5.8).
  void condition_power_up(TimePoint now);
  void condition_configure() noexcept;
  void condition_cycle(const ChannelSample& s, TimePoint now);
  void condition_publish() noexcept;
  void condition_persist();

  void ifm_factory();
  void ifm_adjust(canopen::EntryDef& def) const;
  std::uint32_t ifm_on_write(const canopen::WriteRequest& req);
  void ifm_after_write(std::uint16_t index, std::uint8_t sub);
  void ifm_publish(ChannelSample& s, const ChannelSample& before, bool first);
  void ifm_fault(FaultKind fault, TimePoint now);
  void ifm_life_guarding(bool lost);
  // 0x1800/5 -> 0x6200 and the read-only 0x2200, after a write or a load.
  void ifm_mirror_event_timer() noexcept;

  // Shared by the Novotechnik files: 0x6001 / 0x6002 coupling (A.7.2, C.7.2).
  std::uint32_t novotechnik_scaling_write(const canopen::WriteRequest& req);
  void novotechnik_scaling_after(std::uint16_t index);
};

// Sets a numeric entry from its little-endian bit pattern, whatever its type
// (the typed setters want a value of the entry's own signedness).
std::uint32_t set_raw(canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub, std::uint64_t raw) noexcept;

// A parameter: an entry SDO may write.
[[nodiscard]] bool is_writable(const canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub);

// The node-ID object's value for `node` and back (F§7.4: ifm holds node-ID - 1,
// keeping FFh, unconfigured, as FFh; Novotechnik the node-ID itself).
[[nodiscard]] std::uint8_t node_value(const families::Addressing& a, std::uint8_t node) noexcept;
[[nodiscard]] std::uint8_t node_of_value(const families::Addressing& a, std::uint64_t raw) noexcept;
// The bit-rate object's value for `kbit` (F§7.4 0x3001: an index into the
// family's table; J§1.3.3, E§4.3 0x2001: kbit/s), and back.
[[nodiscard]] std::optional<std::uint64_t> bitrate_value(const families::Addressing& a,
                                                         std::uint16_t kbit) noexcept;
[[nodiscard]] std::uint16_t kbit_of_value(const families::Addressing& a, std::uint64_t raw) noexcept;
// The LSS services the device answers (DeviceSpec::lss over the family's own).
[[nodiscard]] canopen::LssSlaveFeatures lss_features(const DeviceSpec& spec, FamilyId family);

// LSS bit-timing table index <-> kbit/s (CiA 305; J§1.5.2, E§6.2).
[[nodiscard]] std::optional<std::uint8_t> lss_index_for_kbit(std::uint16_t kbit) noexcept;
// ifm 0x3001 value <-> kbit/s (F§7.4: 0 = 20 ... 7 = 1000).
[[nodiscard]] std::uint16_t ifm_kbit(std::uint8_t index) noexcept;
[[nodiscard]] std::optional<std::uint8_t> ifm_index_for_kbit(std::uint16_t kbit) noexcept;

}  // namespace cobridge::sim
