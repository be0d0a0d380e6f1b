#include "register_image.hpp"

#include "command_registers.hpp"

#include <algorithm>
#include <cstring>
#include <thread>
#include <type_traits>

namespace cobridge::modbus {
namespace {

static_assert(std::is_trivially_copyable_v<DeviceState>);

// Valid bits that carry process data: they refresh the data age.
constexpr std::uint16_t kProcessData = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG | COBRIDGE_VALID_SPEED |
                                       COBRIDGE_VALID_CAM_STATE | COBRIDGE_VALID_WORK_AREA_STATE |
                                       COBRIDGE_VALID_ALARMS | COBRIDGE_VALID_WARNINGS |
                                       COBRIDGE_VALID_TEMPERATURE | COBRIDGE_VALID_VOLTAGE;

// A reader gives up after this many torn reads (then 0x04): the writer holds
// a slot for a dozen stores, so this only trips if the writer thread is
// descheduled mid-write again and again.
constexpr int kMaxSnapshotTries = 10000;

template <typename T>
void bump(std::atomic<T>& a, int delta) noexcept {  // single writer: no RMW needed
  a.store(static_cast<T>(static_cast<int>(a.load(std::memory_order_relaxed)) + delta), std::memory_order_relaxed);
}

void put(std::uint16_t* block, const RegisterDef& d, std::uint32_t v, WordOrder order) noexcept {
  if (word_count(d.type) == 2) {
    put_u32(block + d.offset, v, order);
  } else {
    block[d.offset] = static_cast<std::uint16_t>(v);
  }
}

}  // namespace

std::uint16_t data_age_ms(std::uint64_t rx_ns, std::uint64_t now_ns) noexcept {
  if (rx_ns == 0) return 0xFFFF;
  if (now_ns <= rx_ns) return 0;
  const std::uint64_t ms = (now_ns - rx_ns) / 1'000'000u;
  return ms >= 0xFFFF ? static_cast<std::uint16_t>(0xFFFF) : static_cast<std::uint16_t>(ms);
}

void put_u32(std::uint16_t* regs, std::uint32_t v, WordOrder order) noexcept {
  const auto hi = static_cast<std::uint16_t>(v >> 16);
  const auto lo = static_cast<std::uint16_t>(v & 0xFFFFu);
  regs[0] = order == WordOrder::kBig ? hi : lo;
  regs[1] = order == WordOrder::kBig ? lo : hi;
}

RegisterImage::RegisterImage(const ImageOptions& options)
    : options_(options),
      slots_(std::make_unique<Slot[]>(std::min<std::size_t>(options.device_slots, kMaxDeviceSlots))),
      shadow_(std::make_unique<Shadow[]>(std::min<std::size_t>(options.device_slots, kMaxDeviceSlots))) {
  options_.device_slots = std::min(options_.device_slots, kMaxDeviceSlots);
}

RegisterImage::~RegisterImage() = default;

void RegisterImage::publish(std::uint16_t slot, const DeviceState& st) noexcept {
  std::array<std::uint64_t, kWords> raw{};
  std::memcpy(raw.data(), &st, sizeof st);
  Slot& s = slots_[slot];
  const std::uint32_t seq = s.seq.load(std::memory_order_relaxed);
  s.seq.store(seq + 1, std::memory_order_relaxed);
  // Release stores of the data (not a fence: ThreadSanitizer does not model
  // fences): a reader that sees any new word also sees the odd sequence.
  for (std::size_t i = 0; i < kWords; ++i) s.words[i].store(raw[i], std::memory_order_release);
  s.seq.store(seq + 2, std::memory_order_release);
}

bool RegisterImage::snapshot(std::uint16_t slot, DeviceState& out) const noexcept {
  if (slot >= options_.device_slots) return false;
  const Slot& s = slots_[slot];
  std::array<std::uint64_t, kWords> raw{};
  for (int attempt = 0; attempt < kMaxSnapshotTries; ++attempt) {
    const std::uint32_t before = s.seq.load(std::memory_order_acquire);
    if ((before & 1u) == 0) {
      // Acquire loads keep the second sequence load after the data loads.
      for (std::size_t i = 0; i < kWords; ++i) raw[i] = s.words[i].load(std::memory_order_acquire);
      if (s.seq.load(std::memory_order_relaxed) == before) {
        std::memcpy(static_cast<void*>(&out), raw.data(), sizeof out);
        return true;
      }
    }
    // The writer was preempted mid-write: let it finish instead of burning the core.
    if (attempt >= 64) std::this_thread::yield();
  }
  return false;
}

void RegisterImage::account(const DeviceState& st, int sign) noexcept {
  if (st.present == 0) return;
  bump(device_count_, sign);
  if (st.online != 0) bump(devices_online_, sign);
  if (st.bus_index < kMaxBuses) {
    BusCounters& b = buses_[st.bus_index];
    bump(b.devices, sign);
    if (st.online != 0) bump(b.online, sign);
  }
}

void RegisterImage::apply(const cobridge_sample& s) noexcept {
  count_frame(s);
  if (s.device_index >= options_.device_slots) {
    unmapped_.store(unmapped_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    return;
  }
  Shadow& sh = shadow_[s.device_index];
  const DeviceState before = sh.state;
  DeviceState& st = sh.state;
  if (sh.have_sequence) count_drops(s, before.sequence);
  sh.have_sequence = true;
  st.sequence = s.sequence;
  st.present = 1;
  st.node_id = s.node_id;
  st.bus_index = s.bus_index;
  copy_values(s, st);
  if (before.present != st.present || before.online != st.online || before.bus_index != st.bus_index) {
    account(before, -1);
    account(st, +1);
  }
  publish(s.device_index, st);
}

void RegisterImage::count_frame(const cobridge_sample& s) noexcept {
  if (s.bus_index >= kMaxBuses) return;
  BusCounters& bus = buses_[s.bus_index];
  bus.frames.store(bus.frames.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  if (s.bus_index >= bus_count_.load(std::memory_order_relaxed)) {
    bus_count_.store(static_cast<std::uint16_t>(s.bus_index + 1), std::memory_order_relaxed);
  }
}

// Unsigned arithmetic handles the wrap; a huge "gap" is a restart or
// reordering, not a loss.
void RegisterImage::count_drops(const cobridge_sample& s, std::uint32_t last_sequence) noexcept {
  const std::uint32_t gap = s.sequence - (last_sequence + 1u);
  if (gap != 0 && gap < 0x8000'0000u && s.bus_index < kMaxBuses) {
    BusCounters& bus = buses_[s.bus_index];
    bus.drops.store(bus.drops.load(std::memory_order_relaxed) + gap, std::memory_order_relaxed);
  }
}

// The values the sample carries (its valid bits), and what they say about
// the device being online and fresh.
void RegisterImage::copy_values(const cobridge_sample& s, DeviceState& st) noexcept {
  const unsigned v = s.valid;
  if ((v & COBRIDGE_VALID_POSITION) != 0) st.position = s.position;
  if ((v & COBRIDGE_VALID_SPEED) != 0) st.speed = s.speed;
  if ((v & COBRIDGE_VALID_CAM_STATE) != 0) st.cam_state = s.cam_state;
  if ((v & COBRIDGE_VALID_WORK_AREA_STATE) != 0) st.work_area_state = s.work_area_state;
  if ((v & COBRIDGE_VALID_ALARMS) != 0) st.alarms = s.alarms;
  if ((v & COBRIDGE_VALID_WARNINGS) != 0) st.warnings = s.warnings;
  if ((v & COBRIDGE_VALID_TEMPERATURE) != 0) st.temperature_dC = s.temperature_dC;
  if ((v & COBRIDGE_VALID_VOLTAGE) != 0) st.voltage_dV = s.voltage_dV;
  if ((v & COBRIDGE_VALID_NMT_STATE) != 0) st.nmt_state = s.nmt_state;
  if ((v & COBRIDGE_VALID_EMCY) != 0) {
    st.emcy_code = s.emcy_code;
    st.emcy_register = s.emcy_register;
  }
  if ((v & kProcessData) != 0) {
    st.data_rx_ns = s.rx_timestamp_ns;
    // The age is measured on the monotonic clock when the gateway gave it.
    st.data_rx_mono_ns = (s.valid & COBRIDGE_VALID_RX_MONOTONIC) != 0 ? s.rx_monotonic_ns : 0;
    st.stale = 0;  // fresh data ends staleness, as in the decoder
  }
  // A heartbeat is proof of life even without a STATUS sample.
  if (s.kind == COBRIDGE_SAMPLE_HEARTBEAT) st.online = 1;
  if ((v & COBRIDGE_VALID_STATUS) != 0) {
    st.online = s.online != 0 ? 1 : 0;
    st.stale = s.stale != 0 ? 1 : 0;
  }
  st.valid_mask = static_cast<std::uint16_t>(st.valid_mask | v);
}

void RegisterImage::apply(const cobridge_device_info& info) noexcept {
  if (info.device_index >= options_.device_slots) return;
  Shadow& sh = shadow_[info.device_index];
  const DeviceState before = sh.state;
  if (info.change == COBRIDGE_DEVICE_REMOVED) {
    sh = Shadow{};
  } else {
    DeviceState& st = sh.state;
    st.present = 1;
    st.node_id = info.node_id;
    st.bus_index = info.bus_index;
    st.vendor_id = info.vendor_id;
    st.product_code = info.product_code;
    st.serial = info.serial;
    if (info.bus_index < kMaxBuses && info.bus_index >= bus_count_.load(std::memory_order_relaxed)) {
      bus_count_.store(static_cast<std::uint16_t>(info.bus_index + 1), std::memory_order_relaxed);
    }
  }
  account(before, -1);
  account(sh.state, +1);
  publish(info.device_index, sh.state);
}

void RegisterImage::apply(const cobridge_bus_info& info) noexcept {
  if (info.bus_index >= kMaxBuses) return;
  BusCounters& b = buses_[info.bus_index];
  // cobridge_controller_state values are the register's (docs/modbus.md).
  b.controller_state.store(info.state <= COBRIDGE_CONTROLLER_BUS_OFF ? info.state : 0, std::memory_order_relaxed);
  b.tx_errors.store(info.counters_known != 0 ? std::min<std::uint16_t>(info.tx_errors, kCounterUnknown - 1) : kCounterUnknown,
                    std::memory_order_relaxed);
  b.rx_errors.store(info.counters_known != 0 ? std::min<std::uint16_t>(info.rx_errors, kCounterUnknown - 1) : kCounterUnknown,
                    std::memory_order_relaxed);
  b.restarts.store(static_cast<std::uint32_t>(info.restarts), std::memory_order_relaxed);
}

void RegisterImage::render_gateway(std::uint16_t* block, ReadTime now) const noexcept {
  const std::uint64_t start = start_ns_.load(std::memory_order_relaxed);
  const std::uint64_t up = now.monotonic_ns > start ? (now.monotonic_ns - start) / 1'000'000'000u : 0;
  for (const RegisterDef& d : gateway_registers()) {
    std::uint32_t v = 0;
    switch (d.field) {
      case Field::kLayoutVersion: v = kMapVersion; break;
      case Field::kVersionMajor: v = options_.version_major; break;
      case Field::kVersionMinor: v = options_.version_minor; break;
      case Field::kVersionPatch: v = options_.version_patch; break;
      case Field::kUptime: v = static_cast<std::uint32_t>(std::min<std::uint64_t>(up, 0xFFFF'FFFFu)); break;
      case Field::kBusCount: v = bus_count_.load(std::memory_order_relaxed); break;
      case Field::kDeviceCount: v = device_count_.load(std::memory_order_relaxed); break;
      case Field::kDevicesOnline: v = devices_online_.load(std::memory_order_relaxed); break;
      case Field::kDeviceSlots: v = options_.device_slots; break;
      case Field::kSlotBase: v = kDeviceBase; break;
      case Field::kSlotStride: v = kDeviceStride; break;
      case Field::kWordOrder: v = static_cast<std::uint32_t>(options_.word_order); break;
      case Field::kWritesEnabled: v = options_.writes_enabled ? 1u : 0u; break;
      case Field::kOfflineException: v = options_.offline_exception ? 1u : 0u; break;
      default: break;
    }
    put(block, d, v, options_.word_order);
  }
}

void RegisterImage::render_bus(std::uint16_t bus, std::uint16_t* block) const noexcept {
  const BusCounters& b = buses_[bus];
  const std::uint16_t devices = b.devices.load(std::memory_order_relaxed);
  const std::uint16_t online = b.online.load(std::memory_order_relaxed);
  for (const RegisterDef& d : bus_registers()) {
    std::uint32_t v = 0;
    switch (d.field) {
      case Field::kBusState: {
        BusState state = BusState::kUnknown;
        if (devices != 0) {
          state = online == devices ? BusState::kOk : online == 0 ? BusState::kDown : BusState::kDegraded;
        }
        v = static_cast<std::uint32_t>(state);
        break;
      }
      case Field::kBusDevices: v = devices; break;
      case Field::kBusOnline: v = online; break;
      case Field::kBusFrames: v = b.frames.load(std::memory_order_relaxed); break;
      case Field::kBusDrops: v = b.drops.load(std::memory_order_relaxed); break;
      case Field::kBusControllerState: v = b.controller_state.load(std::memory_order_relaxed); break;
      default: break;
    }
    put(block, d, v, options_.word_order);
  }
}

void RegisterImage::render_controller(std::uint16_t bus, std::uint16_t* block) const noexcept {
  const BusCounters& b = buses_[bus];
  for (const RegisterDef& d : controller_registers()) {
    std::uint32_t v = 0;
    switch (d.field) {
      case Field::kControllerTxErrors: v = b.tx_errors.load(std::memory_order_relaxed); break;
      case Field::kControllerRxErrors: v = b.rx_errors.load(std::memory_order_relaxed); break;
      case Field::kControllerRestarts: v = b.restarts.load(std::memory_order_relaxed); break;
      default: break;
    }
    put(block, d, v, options_.word_order);
  }
}

void RegisterImage::render_device(std::uint16_t slot, const DeviceState& st, std::uint16_t* block,
                                  ReadTime now) const noexcept {
  if (st.present == 0) return;  // an empty slot reads as zeros
  for (const RegisterDef& d : device_registers()) {
    std::uint32_t v = 0;
    switch (d.field) {
      case Field::kPosition: v = static_cast<std::uint32_t>(static_cast<std::uint64_t>(st.position)); break;
      case Field::kSpeed: v = static_cast<std::uint32_t>(st.speed); break;
      case Field::kCamState: v = st.cam_state; break;
      case Field::kWorkAreaState: v = st.work_area_state; break;
      case Field::kAlarms: v = st.alarms; break;
      case Field::kWarnings: v = st.warnings; break;
      case Field::kNmtState: v = st.nmt_state; break;
      case Field::kOnline: v = st.online; break;
      case Field::kStale: v = st.stale; break;
      case Field::kDataAge:
        v = st.data_rx_mono_ns != 0 ? data_age_ms(st.data_rx_mono_ns, now.monotonic_ns)
                                    : data_age_ms(st.data_rx_ns, now.realtime_ns);
        break;
      case Field::kSequence: v = st.sequence; break;
      case Field::kEmcyCode: v = st.emcy_code; break;
      case Field::kEmcyRegister: v = st.emcy_register; break;
      case Field::kTemperature: v = static_cast<std::uint16_t>(st.temperature_dC); break;
      case Field::kVoltage: v = st.voltage_dV; break;
      case Field::kNodeId: v = st.node_id; break;
      case Field::kBusIndex: v = st.bus_index; break;
      case Field::kSerial: v = st.serial; break;
      case Field::kVendorId: v = st.vendor_id; break;
      case Field::kProductCode: v = st.product_code; break;
      case Field::kPresent: v = st.present; break;
      case Field::kValidMask: v = st.valid_mask; break;
      default: continue;  // the command registers, below
    }
    put(block, d, v, options_.word_order);
  }
  if (commands_ != nullptr) commands_->render(slot, block);
}

ReadStatus RegisterImage::read(std::uint16_t address, std::span<std::uint16_t> out, ReadTime now,
                               bool offline_check) const noexcept {
  const std::uint32_t first = address;
  const std::uint32_t end = first + static_cast<std::uint32_t>(out.size());
  if (end > size()) return ReadStatus::kOutOfRange;
  std::uint32_t pos = first;
  if (pos < kDeviceBase) {
    std::array<std::uint16_t, kDeviceBase> low{};
    render_gateway(low.data() + kGatewayBase, now);
    for (std::uint16_t b = 0; b < kMaxBuses; ++b) {
      render_bus(b, low.data() + bus_base(b));
      render_controller(b, low.data() + controller_base(b));
    }
    const std::uint32_t stop = std::min<std::uint32_t>(end, kDeviceBase);
    std::copy(low.begin() + pos, low.begin() + stop, out.begin());
    pos = stop;
  }
  while (pos < end) {
    const auto slot = static_cast<std::uint16_t>((pos - kDeviceBase) / kDeviceStride);
    DeviceState st;
    if (!snapshot(slot, st)) return ReadStatus::kBusy;
    if (offline_check && st.present != 0 && st.online == 0) return ReadStatus::kOffline;
    std::array<std::uint16_t, kDeviceStride> block{};
    render_device(slot, st, block.data(), now);
    const std::uint32_t base = device_base(slot);
    const std::uint32_t stop = std::min<std::uint32_t>(end, base + kDeviceStride);
    std::copy(block.begin() + (pos - base), block.begin() + (stop - base), out.begin() + (pos - first));
    pos = stop;
  }
  return ReadStatus::kOk;
}

}  // namespace cobridge::modbus
