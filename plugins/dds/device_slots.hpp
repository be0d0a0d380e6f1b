// DeviceSlots: the DDS plugin's fixed table of what it knows per device,
// indexed by cobridge_sample.device_index: the strings of the last
// cobridge_device_info (so that samples can carry the device name without
// allocating), the DeviceStatus state built from heartbeat, NMT, status and
// EMCY samples, and the last TPDO sample (re-published with stale = true when
// the gateway declares the device stale).
//
// Status ahead of samples: heartbeat, NMT and STATUS samples reach the table
// twice, first through apply_ahead() from the plugin's status lane, which
// the writer thread serves before the sample queue, then through apply() in
// the queue's order. A status change therefore never waits behind a backlog
// of EncoderSamples (a slow reliable subscriber, a loaded host: seconds).
// Each slot keeps the per-device `sequence` (plugin.h) of the last status
// applied ahead; in the queue, a status sample not newer than it is skipped
// (applied already, or older than the state shown) and an older TPDO does
// not end `stale`; the first sample past it ends the comparison. Numbers,
// not counts: the lane may drop, and may even see a sample the queue has
// already taken (both are pushed one after the other).
//
// The table is allocated once, at construction; nothing in it allocates
// afterwards. Strings longer than their slot are cut at a UTF-8 character
// boundary.
//
// Thread contract: the plugin's writer thread (DdsPublisher) between start
// and stop; the control thread otherwise. Never both at once, so there is
// no lock.
#pragma once

#include <cobridge/plugin.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cobridge::dds {

// A NUL-terminated string of at most N-1 bytes, stored inline.
template <std::size_t N>
struct FixedString {
  std::array<char, N> text{};
  void assign(const char* s) noexcept;
  [[nodiscard]] const char* c_str() const noexcept { return text.data(); }
};

// What DeviceStatus publishes, besides the identity strings.
struct DeviceState {
  std::uint8_t nmt_state = COBRIDGE_NMT_BOOT_UP;
  bool online = false;
  bool stale = false;
  std::uint16_t last_emcy_code = 0;
  std::uint8_t last_emcy_register = 0;
  std::uint64_t last_emcy_ns = 0;
  std::uint64_t updated_ns = 0;

  // Everything but updated_ns: a change of these is worth a new sample.
  [[nodiscard]] bool same_as(const DeviceState& o) const noexcept {
    return nmt_state == o.nmt_state && online == o.online && stale == o.stale &&
           last_emcy_code == o.last_emcy_code && last_emcy_register == o.last_emcy_register &&
           last_emcy_ns == o.last_emcy_ns;
  }
};

struct DeviceSlot {
  bool in_use = false;     // announced by on_device or seen in a sample
  bool announced = false;  // on_device gave identity and strings
  std::uint8_t bus_index = 0;
  std::uint8_t node_id = 0;
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
  std::uint32_t revision = 0;
  std::uint32_t serial = 0;
  FixedString<64> name;
  FixedString<32> bus_name;
  FixedString<64> model;
  FixedString<48> family;
  FixedString<16> position_unit;
  std::uint8_t config_state = COBRIDGE_CONFIG_AS_CONFIGURED;  // ABI 6 on_device
  DeviceState state;
  bool has_last_tpdo = false;
  cobridge_sample last_tpdo{};
  // A status was applied ahead of the queue: its `sequence`, until the
  // queue passes it.
  bool ahead = false;
  std::uint32_t ahead_sequence = 0;
  // EncoderSample side, in queue order: the last TPDO was re-published
  // stale and no TPDO (or STATUS not stale) came since.
  bool samples_stale = false;
};

// Heartbeat, NMT state and STATUS: the samples that travel the status lane.
[[nodiscard]] bool is_status_kind(const cobridge_sample& sample) noexcept;

// What a sample did to its slot's DeviceStatus.
enum class StatusChange : std::uint8_t {
  kNone,        // nothing DeviceStatus shows changed
  kChanged,     // publish DeviceStatus
  kBecameStale  // publish DeviceStatus, and re-publish the last TPDO as stale
};

class DeviceSlots {
 public:
  // 127 nodes on each of 8 buses.
  static constexpr std::size_t kDefaultCapacity = 1016;

  explicit DeviceSlots(std::size_t capacity = kDefaultCapacity);

  [[nodiscard]] std::size_t capacity() const noexcept { return slots_.size(); }
  // nullptr when device_index is beyond the table.
  [[nodiscard]] DeviceSlot* find(std::uint16_t device_index) noexcept;
  [[nodiscard]] const DeviceSlot* find(std::uint16_t device_index) const noexcept;

  // Copies the announced identity and strings. Returns the slot, or nullptr
  // when the index is beyond the table. REMOVED clears the slot (the caller
  // disposes the DDS instance first, from the key it still holds).
  DeviceSlot* apply(const cobridge_device_info& info) noexcept;

  // Updates the slot of a sample: the last TPDO, and the DeviceStatus state
  // from heartbeat (NMT state, online), NMT state, STATUS (online, stale,
  // NMT state) and EMCY (last code) samples. Returns what changed; kNone for
  // a sample whose device_index is beyond the table.
  // In queue order: a status sample not newer than one applied ahead is
  // skipped (kNone).
  StatusChange apply(const cobridge_sample& sample) noexcept;
  // A status sample (is_status_kind) from the status lane, before the queue
  // has reached it: applied now and remembered by its sequence, so apply()
  // skips it later. kNone for other kinds (they wait for the queue).
  StatusChange apply_ahead(const cobridge_sample& sample) noexcept;

 private:
  StatusChange update(DeviceSlot& slot, const cobridge_sample& sample, bool older_than_shown) noexcept;

  std::vector<DeviceSlot> slots_;
};

}  // namespace cobridge::dds
