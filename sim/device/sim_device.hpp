// SimDevice: one simulated encoder on a CAN bus, a CANopen device that follows
// its manual (J: Novotechnik rotary, E: Novotechnik multiturn, F: ifm RM8/RM9).
//
// The object dictionary is built from the family's EDS file (config/devices/,
// the same files the daemon reads); behaviour lives in code: NMT slave, SDO
// server, LSS slave (feature set per LSS version), heartbeat producer, node
// guarding responder with life guarding, TPDO1/TPDO2 (event timer, SYNC,
// measuring-cycle type 255, inhibit time, RTR where the manual has it),
// EMCY producer, the reactions of its CAN controller to the bus state the
// simulator announces with Linux CAN error frames (error passive, bus-off,
// restart; J§1.8.1, E§9.1), non-volatile storage per serial under the state
// directory, and the encoder functions (position, speed, scaling, preset,
// CAMs, work area, alarms/warnings, condition monitoring, faults).
//
// Like every protocol component it never reads a clock and never sleeps:
// frames and `now` go in, `process(now)` returns the next deadline.
// Thread: owned by the simulator's bus thread; not thread-safe.
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss.hpp"
#include "canopen/lss_slave.hpp"
#include "canopen/nmt.hpp"
#include "canopen/object_dictionary.hpp"
#include "device/eds.hpp"
#include "families/family.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

namespace cobridge::sim {

using canopen::TimePoint;

using families::FamilyId;

// One row of the model table (sim_models.cpp): what `--device MODEL` means.
struct ModelInfo {
  std::string_view name;        // "RFC-4800", "MC1-2800", "RM9000", ...
  FamilyId family;
  std::uint32_t vendor;         // 0x1018/1
  std::uint32_t product;        // 0x1018/2
  std::uint8_t factory_node_id; // 127 (Novotechnik), 32 (ifm)
  bool legacy_rsx_rfx;          // J§1.12: RSX-7900 / RFX-6900 firmware rules
  std::string_view eds_stem;    // config/devices/<stem>[-1ch|-2ch].eds
  std::uint16_t factory_bitrate_kbit = 0;  // 250 (Novotechnik ordering code _4), 125 (ifm F§5.3.2)
};

// All models; find_model is case-insensitive. nullptr if unknown.
[[nodiscard]] const ModelInfo* find_model(std::string_view name) noexcept;
[[nodiscard]] std::string_view family_name(FamilyId f) noexcept;
// The family's facts (daemon/families): identity, bit rates, quirks.
[[nodiscard]] const families::Family& family_facts(FamilyId f) noexcept;
// The whole table, for `--list-models` and the tests.
[[nodiscard]] std::span<const ModelInfo> all_models() noexcept;

// The LSS feature set a device answers with (cobridge-sim key lss=...).
enum class LssProfile : std::uint8_t {
  family_default,  // rotary: v1 (J claims DSP-305 V1.1.2); multiturn: v3; ifm: v3
  v1,              // switch, configure, store, identify remote slave; no inquire, no Fastscan
  v3,              // all CiA 305 V3 services including Fastscan and inquire
  none,            // no LSS at all
};

// Everything `--device MODEL:key=value,...` can say.
struct DeviceSpec {
  const ModelInfo* model = nullptr;
  std::uint32_t serial = 0;
  std::uint8_t node_id = 0;       // 0 = the model's factory node-ID; 0xFF = unconfigured
  std::uint8_t channels = 1;      // rotary: 1 or 2
  std::uint16_t bitrate_kbit = 0; // 0 = family default (ordering code / 125 for ifm)
  LssProfile lss = LssProfile::family_default;
  bool segmented_sdo = true;      // on: J§1.3.1 strings (0x1008) exceed 4 bytes
  std::string motion = "constant:0";  // see motion.hpp for the grammar
  // ifm "C6" variant: TPDO2 (0x1801) is "only active for CANopen C6 encoders"
  // (F§7.3 0x1801). Off by default: plain RM8/RM9 send TPDO1 only.
  bool ifm_c6 = false;
  // Fastscan answered only while unconfigured anyway (CiA 305 V3 Fastscan); this
  // switch removes it even from a v3 LSS profile.
  bool lss_fastscan = true;
  // Another vendor's (or an unknown) device: identity fields instead of the
  // model's (0x1018/1..3 and the LSS address), with the model's behaviour.
  std::optional<std::uint32_t> vendor;
  std::optional<std::uint32_t> product;
  std::optional<std::uint32_t> revision;
  // How it takes an LSS configure node-ID: accept, refuse (error 1) or ignore.
  canopen::LssSlaveFeatures::NodeIdAssignment assign = canopen::LssSlaveFeatures::NodeIdAssignment::accept;
  std::uint8_t lose_configure = 0;  // the first N LSS configure node-ID requests unanswered
  std::uint8_t late_lss = 0;        // every Nth LSS answer leaves late_lss_ms late (0: none)
  std::uint16_t late_lss_ms = 0;
};

// Faults injected at run time (control socket / stdin / command line).
enum class FaultKind : std::uint8_t {
  measurement_error,      // E 0x5051/1/0 position 0x7FFFFFFC; J 0x5000 position 0x7FF0
  over_range,             // E 0x5051/1/1 position 0x7FFFFFF8 (latched until 0x2100)
  under_range,            // E 0x5051/1/2 position 0x80000008
  hardware_fault,         // E 0x5000/1/0; J 0x5000
  temperature_high,       // E 0x4210/1/1, 0x1002 bit 4
  temperature_low,        // E 0x4210/1/2
  voltage_high,           // E 0x3100/1/1
  voltage_low,            // E 0x3100/1/2
  channel_disagreement,   // J 2-channel: 0x6503 bit 0
  clear,                  // the condition ends (EMCY 0x0000 where the manual says so)
};

// What the device put on the bus, decoded (ground truth for end-to-end tests).
struct TruthRecord {
  std::uint32_t serial = 0;
  std::uint8_t node_id = 0;
  // As sent. SimDevice reads no clock, so it leaves timestamp_ns 0; the
  // simulator (sim/app) stamps it with CLOCK_REALTIME read in the truth
  // sink, i.e. right after the frame was written to the CAN socket.
  can::Frame frame;
  enum class Kind : std::uint8_t { tpdo, emcy, heartbeat, boot_up, sdo, lss, guard } kind = Kind::tpdo;
  std::uint8_t pdo = 0;           // 1 or 2 for TPDOs
  bool has_position = false;
  std::int64_t position = 0;      // position ch1 as mapped (after scaling/preset/error values)
  bool has_speed = false;
  std::int32_t speed = 0;
  std::int16_t cam_state = -1;    // -1 = not mapped
  std::int16_t work_area_state = -1;
  std::uint16_t emcy_code = 0;
};
using TruthSink = std::function<void(const TruthRecord&)>;

class SimDevice {
 public:
  // `description` must outlive the device. `state_dir` holds the device's
  // non-volatile memory (<state_dir>/<family>-<serial>.nv); empty = volatile.
  SimDevice(DeviceSpec spec, const device::DeviceDescription& description, can::FrameSink& sink,
            std::filesystem::path state_dir);
  ~SimDevice();
  SimDevice(const SimDevice&) = delete;
  SimDevice& operator=(const SimDevice&) = delete;

  // Power on: load non-volatile memory (by serial), build the object
  // dictionary, send the boot-up (0x700+node, 00) unless unconfigured (FFh).
  // A failure names its place (the non-volatile memory file, the EDS entry,
  // the motion spec).
  Error power_on(TimePoint now);
  void power_off();                        // silent until power_on; RAM lost
  Error power_cycle(TimePoint now) { power_off(); return power_on(now); }
  void set_silent(bool silent);            // cable pulled: no RX, no TX, state kept
  // Power-cycles the device when the n-th SDO request (0x600+node) from now
  // arrives, instead of answering it: a reboot in the middle of a master's
  // transfer (0 cancels). Survives nothing: the count is cleared by the reboot.
  void reboot_on_sdo(std::uint32_t nth) noexcept;
  // Answers the next SDO initiate request (upload or download) for `index`
  // with an abort of `code` (CiA 301 §7.2.4.3.17) instead of serving it: a
  // configuration fault. One request only; index 0 cancels; a reboot clears it.
  void abort_sdo(std::uint16_t index, std::uint32_t code) noexcept;
  // Leaves the next `n` SDO initiate requests for `index` unanswered (lost,
  // as far as the master can tell: an SDO timeout). 0 cancels; a reboot clears it.
  void ignore_sdo(std::uint16_t index, std::uint32_t n) noexcept;
  // Leaves the next `n` NMT start commands (CiA 301 §7.2.8.3.1) unacted: a
  // device that missed or is slow to act on a master's start, its heartbeat
  // still saying pre-operational. 0 cancels; a reboot clears it.
  void ignore_nmt_start(std::uint32_t n) noexcept;
  [[nodiscard]] bool powered() const noexcept;

  void on_frame(const can::Frame& frame, TimePoint now);
  [[nodiscard]] TimePoint process(TimePoint now);
  void inject(FaultKind fault, TimePoint now);

  void set_truth_sink(TruthSink sink);

  [[nodiscard]] const DeviceSpec& spec() const noexcept;
  [[nodiscard]] std::uint8_t node_id() const noexcept;     // active node-ID (0xFF = unconfigured)
  [[nodiscard]] std::uint64_t late_lss_answers() const noexcept;  // sent late (late_lss) so far
  [[nodiscard]] canopen::NmtState nmt_state() const noexcept;
  [[nodiscard]] canopen::LssAddress identity() const noexcept;

  // --- additions for the simulator app and the tests ---------------------
  // Active bit rate in kbit/s (changes only on reset communication / power
  // up, or LSS activate bit timing; the simulator cannot retune a vcan).
  [[nodiscard]] std::uint16_t bitrate_kbit() const noexcept;
  // The live object dictionary (nullptr while powered off). Reading it is
  // how tests and the control interface inspect the device without SDO.
  [[nodiscard]] const canopen::ObjectDictionary* object_dictionary() const noexcept;
  // <state_dir>/<family>-<serial>.nv, or empty when volatile.
  [[nodiscard]] const std::filesystem::path& nv_path() const noexcept;
  // Replaces the motion (same grammar as DeviceSpec::motion) at run time.
  Error set_motion(std::string_view motion, TimePoint now);
  // Turns the shaft by `turns` at once (control `move`; negative and
  // fractional allowed). The offset adds up and survives set_motion and power
  // cycles (an absolute encoder sees where the shaft went); the position
  // objects follow at the next 1 ms measuring cycle.
  void move_by(double turns) noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cobridge::sim
