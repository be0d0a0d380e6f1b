// RegisterImage: the current value of every register of the Modbus map,
// written by the dispatcher thread (apply) and read by the Modbus server
// thread (read), neither waiting for the other.
//
// Each device slot is a seqlock: the single writer bumps the slot's sequence
// to odd, stores the slot's words, bumps it to even; a reader copies the
// words and retries if the sequence was odd or moved. The writer never waits;
// a reader retries only while a write of ~10 stores is in flight. Values are
// kept raw (position, timestamps, ...) and turned into registers at read time,
// so the data age is computed when the client asks, and word order is a
// property of the read. Bus and gateway counters are relaxed atomics; so
// are a bus's CAN controller figures (on_bus, ABI 5), each register whole,
// the state and counters possibly from two consecutive reports.
//
// The command registers of each slot (+28..+31) are not in the seqlock: they
// belong to CommandRegisters, which read() asks when one is attached.
//
// Thread contract: apply() from one thread only (the dispatcher); read()
// from any number of threads; attach() before the first read. No
// allocation after construction, noexcept.
#pragma once

#include "register_map.hpp"

#include <cobridge/plugin.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <span>

namespace cobridge::modbus {

class CommandRegisters;

enum class WordOrder : std::uint8_t { kBig = 0, kLittle = 1 };

struct ImageOptions {
  std::uint16_t device_slots = 32;
  WordOrder word_order = WordOrder::kBig;
  bool writes_enabled = false;
  bool offline_exception = false;
  std::uint16_t version_major = 0;
  std::uint16_t version_minor = 0;
  std::uint16_t version_patch = 0;
};

// The clocks a read needs: wall clock for the data age (sample timestamps
// are CLOCK_REALTIME ns), monotonic for the uptime.
struct ReadTime {
  std::uint64_t realtime_ns = 0;
  std::uint64_t monotonic_ns = 0;
};

enum class ReadStatus : std::uint8_t {
  kOk,
  kOutOfRange,  // address + count beyond the map -> 0x02
  kOffline,     // a touched slot's device is offline (only if asked) -> 0x0B
  kBusy,        // no consistent snapshot after many retries -> 0x04
};

// One device as stored in a slot; trivially copyable, copied word-wise.
struct DeviceState {
  std::int64_t position = 0;
  std::uint64_t data_rx_ns = 0;       // rx timestamp of the latest process data; 0 = none
  std::uint64_t data_rx_mono_ns = 0;  // the same on CLOCK_MONOTONIC (the data age uses it); 0 = not given
  std::int32_t speed = 0;
  std::uint32_t sequence = 0;
  std::uint32_t serial = 0;
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
  std::uint16_t alarms = 0;
  std::uint16_t warnings = 0;
  std::uint16_t emcy_code = 0;
  std::uint16_t valid_mask = 0;
  std::int16_t temperature_dC = 0;
  std::uint16_t voltage_dV = 0;
  std::uint8_t cam_state = 0;
  std::uint8_t work_area_state = 0;
  std::uint8_t nmt_state = 0;
  std::uint8_t online = 0;
  std::uint8_t stale = 0;
  std::uint8_t emcy_register = 0;
  std::uint8_t node_id = 0;
  std::uint8_t bus_index = 0;
  std::uint8_t present = 0;
};

// Milliseconds between `rx_ns` and `now_ns`, saturated to 65535; 65535 also
// when no data was ever received. A timestamp in the future reads as 0.
[[nodiscard]] std::uint16_t data_age_ms(std::uint64_t rx_ns, std::uint64_t now_ns) noexcept;

// Writes a 32-bit value into two registers in the given word order.
void put_u32(std::uint16_t* regs, std::uint32_t v, WordOrder order) noexcept;

class RegisterImage {
 public:
  explicit RegisterImage(const ImageOptions& options);
  ~RegisterImage();
  RegisterImage(const RegisterImage&) = delete;
  RegisterImage& operator=(const RegisterImage&) = delete;

  [[nodiscard]] const ImageOptions& options() const noexcept { return options_; }
  [[nodiscard]] std::uint32_t size() const noexcept { return map_size(options_.device_slots); }

  // Writer side (dispatcher thread).
  void apply(const cobridge_sample& s) noexcept;
  void apply(const cobridge_device_info& info) noexcept;
  void apply(const cobridge_bus_info& info) noexcept;
  // Renders +28..+31 of every present slot from `commands` (may be nullptr).
  void attach(const CommandRegisters* commands) noexcept { commands_ = commands; }
  // Marks the start of the uptime count.
  void set_start(std::uint64_t monotonic_ns) noexcept { start_ns_.store(monotonic_ns, std::memory_order_relaxed); }

  // Reader side (any thread): renders registers [address, address+out.size()).
  [[nodiscard]] ReadStatus read(std::uint16_t address, std::span<std::uint16_t> out, ReadTime now,
                                bool offline_check) const noexcept;

  // A consistent copy of one slot; false if the seqlock never settled.
  [[nodiscard]] bool snapshot(std::uint16_t slot, DeviceState& out) const noexcept;

  // Samples whose device_index has no slot (counted, not stored).
  [[nodiscard]] std::uint64_t unmapped_samples() const noexcept {
    return unmapped_.load(std::memory_order_relaxed);
  }

 private:
  static constexpr std::size_t kWords = (sizeof(DeviceState) + 7) / 8;
  struct alignas(64) Slot {
    std::atomic<std::uint32_t> seq{0};
    std::array<std::atomic<std::uint64_t>, kWords> words{};
  };
  struct Shadow {  // writer-private per slot
    DeviceState state;
    bool have_sequence = false;
  };
  struct alignas(64) BusCounters {
    std::atomic<std::uint32_t> frames{0};
    std::atomic<std::uint32_t> drops{0};
    std::atomic<std::uint16_t> devices{0};
    std::atomic<std::uint16_t> online{0};
    // The CAN controller (cobridge_bus_info); unknown until a daemon with ABI 5 tells it.
    std::atomic<std::uint16_t> controller_state{0};
    std::atomic<std::uint16_t> tx_errors{kCounterUnknown};
    std::atomic<std::uint16_t> rx_errors{kCounterUnknown};
    std::atomic<std::uint32_t> restarts{0};
  };

  void publish(std::uint16_t slot, const DeviceState& st) noexcept;
  void account(const DeviceState& st, int sign) noexcept;
  void count_frame(const cobridge_sample& s) noexcept;
  void count_drops(const cobridge_sample& s, std::uint32_t last_sequence) noexcept;
  static void copy_values(const cobridge_sample& s, DeviceState& st) noexcept;
  void render_gateway(std::uint16_t* block, ReadTime now) const noexcept;
  void render_bus(std::uint16_t bus, std::uint16_t* block) const noexcept;
  void render_controller(std::uint16_t bus, std::uint16_t* block) const noexcept;
  void render_device(std::uint16_t slot, const DeviceState& st, std::uint16_t* block, ReadTime now) const noexcept;

  ImageOptions options_;
  std::unique_ptr<Slot[]> slots_;
  std::unique_ptr<Shadow[]> shadow_;
  std::array<BusCounters, kMaxBuses> buses_{};
  std::atomic<std::uint16_t> bus_count_{0};
  std::atomic<std::uint16_t> device_count_{0};
  std::atomic<std::uint16_t> devices_online_{0};
  std::atomic<std::uint64_t> start_ns_{0};
  std::atomic<std::uint64_t> unmapped_{0};
  const CommandRegisters* commands_ = nullptr;
};

}  // namespace cobridge::modbus
