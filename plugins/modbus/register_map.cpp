#include "register_map.hpp"

#include <array>
#include <charconv>

namespace cobridge::modbus {
namespace {

constexpr Access R = Access::kRead;
constexpr Access RW = Access::kReadWrite;

constexpr std::array kGateway = {
    RegisterDef{0, RegType::kU16, Field::kLayoutVersion, "map_version", "", 1, R,
                "layout version of this register map (3)"},
    RegisterDef{1, RegType::kU16, Field::kVersionMajor, "version_major", "", 1, R, "gateway software version, major"},
    RegisterDef{2, RegType::kU16, Field::kVersionMinor, "version_minor", "", 1, R, "gateway software version, minor"},
    RegisterDef{3, RegType::kU16, Field::kVersionPatch, "version_patch", "", 1, R, "gateway software version, patch"},
    RegisterDef{4, RegType::kU32, Field::kUptime, "uptime", "s", 1, R, "seconds since the Modbus output started"},
    RegisterDef{6, RegType::kU16, Field::kBusCount, "bus_count", "", 1, R,
                "number of buses seen (highest bus index + 1)"},
    RegisterDef{7, RegType::kU16, Field::kDeviceCount, "device_count", "", 1, R, "devices known to the gateway"},
    RegisterDef{8, RegType::kU16, Field::kDevicesOnline, "devices_online", "", 1, R, "devices currently online"},
    RegisterDef{9, RegType::kU16, Field::kDeviceSlots, "device_slots", "", 1, R,
                "number of device slots in this map (max_devices)"},
    RegisterDef{10, RegType::kU16, Field::kSlotBase, "device_base", "", 1, R, "address of device slot 0 (256)"},
    RegisterDef{11, RegType::kU16, Field::kSlotStride, "device_stride", "", 1, R, "registers per device slot (32)"},
    RegisterDef{12, RegType::kU16, Field::kWordOrder, "word_order", "", 1, R,
                "word order of 32-bit values: 0 = big (high word first), 1 = little"},
    RegisterDef{13, RegType::kU16, Field::kWritesEnabled, "writes_enabled", "", 1, R, "1 if writes_enabled = true"},
    RegisterDef{14, RegType::kU16, Field::kOfflineException, "offline_exception", "", 1, R,
                "1 if reads of an offline device answer exception 0x0B"},
};

constexpr std::array kBus = {
    RegisterDef{0, RegType::kU16, Field::kBusState, "state", "", 1, R,
                "0 = no device seen, 1 = all devices online, 2 = some offline, 3 = all offline"},
    RegisterDef{1, RegType::kU16, Field::kBusDevices, "devices", "", 1, R, "devices on this bus"},
    RegisterDef{2, RegType::kU16, Field::kBusOnline, "devices_online", "", 1, R, "devices online on this bus"},
    RegisterDef{3, RegType::kU16, Field::kBusControllerState, "controller_state", "", 1, R,
                "CAN controller: 0 = unknown (no error frame or netlink state yet), 1 = error-active, "
                "2 = error-warning, 3 = error-passive, 4 = bus-off"},
    RegisterDef{4, RegType::kU32, Field::kBusFrames, "frames", "", 1, R,
                "samples received from this bus (decoded frames), wraps"},
    RegisterDef{6, RegType::kU32, Field::kBusDrops, "drops", "", 1, R,
                "samples lost before the output (gaps in the per-device sequence), wraps"},
};

constexpr std::array kController = {
    RegisterDef{0, RegType::kU16, Field::kControllerTxErrors, "tx_errors", "", 1, R,
                "CAN controller transmit error counter; 65535 = not reported by the driver"},
    RegisterDef{1, RegType::kU16, Field::kControllerRxErrors, "rx_errors", "", 1, R,
                "CAN controller receive error counter; 65535 = not reported by the driver"},
    RegisterDef{2, RegType::kU32, Field::kControllerRestarts, "restarts", "", 1, R,
                "controller restarts after bus-off, wraps"},
};

constexpr std::array kDevice = {
    RegisterDef{0, RegType::kI32, Field::kPosition, "position", "counts", 1, R,
                "position after the device's scaling (0x6004 / 0x6020), low 32 bits; read as UINT32 for "
                "devices with an UNSIGNED32 position"},
    RegisterDef{2, RegType::kI32, Field::kSpeed, "speed", "device units", 1, R, "speed value (0x6030)"},
    RegisterDef{4, RegType::kU16, Field::kCamState, "cam_state", "bits", 1, R,
                "CAM state register channel 1 (0x6300/1), bit n = CAM n+1"},
    RegisterDef{5, RegType::kU16, Field::kWorkAreaState, "work_area_state", "bits", 1, R,
                "work area state register (0x6400/1)"},
    RegisterDef{6, RegType::kU16, Field::kAlarms, "alarms", "bits", 1, R, "alarm bits (0x6503)"},
    RegisterDef{7, RegType::kU16, Field::kWarnings, "warnings", "bits", 1, R, "warning bits (0x6505)"},
    RegisterDef{8, RegType::kU16, Field::kNmtState, "nmt_state", "", 1, R,
                "NMT state: 0 boot-up, 4 stopped, 5 operational, 127 pre-operational"},
    RegisterDef{9, RegType::kU16, Field::kOnline, "online", "", 1, R, "1 = the gateway hears the node"},
    RegisterDef{10, RegType::kU16, Field::kStale, "stale", "", 1, R,
                "1 = the values are older than the device's max age"},
    RegisterDef{11, RegType::kU16, Field::kDataAge, "data_age", "ms", 1, R,
                "age of the process data at the time of the read (from the CAN receive timestamp); 65535 = "
                "never received or older than 65.534 s"},
    RegisterDef{12, RegType::kU32, Field::kSequence, "sequence", "", 1, R,
                "sequence number of the device's latest sample, wraps"},
    RegisterDef{14, RegType::kU16, Field::kEmcyCode, "emcy_code", "", 1, R,
                "last EMCY error code (0 = none or error reset)"},
    RegisterDef{15, RegType::kU16, Field::kEmcyRegister, "emcy_register", "bits", 1, R,
                "error register (0x1001) from the last EMCY"},
    RegisterDef{16, RegType::kI16, Field::kTemperature, "temperature", "degC", 0.1, R, "device temperature"},
    RegisterDef{17, RegType::kU16, Field::kVoltage, "voltage", "V", 0.1, R, "supply voltage"},
    RegisterDef{18, RegType::kU16, Field::kNodeId, "node_id", "", 1, R, "CANopen node-ID 1..127"},
    RegisterDef{19, RegType::kU16, Field::kBusIndex, "bus_index", "", 1, R, "index of the device's bus"},
    RegisterDef{20, RegType::kU32, Field::kSerial, "serial", "", 1, R, "serial number (0x1018/4)"},
    RegisterDef{22, RegType::kU32, Field::kVendorId, "vendor_id", "", 1, R, "vendor-ID (0x1018/1)"},
    RegisterDef{24, RegType::kU32, Field::kProductCode, "product_code", "", 1, R, "product code (0x1018/2)"},
    RegisterDef{26, RegType::kU16, Field::kPresent, "present", "", 1, R,
                "1 = a device occupies this slot; 0 = empty slot (all registers 0)"},
    RegisterDef{27, RegType::kU16, Field::kValidMask, "valid_mask", "bits", 1, R,
                "fields ever received (cobridge_sample valid bits, plugin.h)"},
    RegisterDef{28, RegType::kI32, Field::kCommandValue, "command_value", "counts", 1, RW,
                "argument of the next command: the preset position (writes_enabled only)"},
    RegisterDef{30, RegType::kU16, Field::kCommand, "command", "", 1, RW,
                "write 1 = preset to command_value, 2 = NMT reset node, 3 = store parameters; reads the last "
                "command submitted (writes_enabled only)"},
    RegisterDef{31, RegType::kU16, Field::kCommandStatus, "command_status", "", 1, R,
                "0 = none, 1 = pending, 2 = done, 3 = unknown device, 4 = offline, 5 = busy, 6 = unsupported, "
                "7 = value out of range, 8 = refused by the device, 9 = no answer, 10 = failed"},
};

// Layout invariants: sorted, non-overlapping, inside the block.
constexpr bool well_formed(const auto& defs, std::uint16_t block) {
  std::uint32_t next = 0;
  for (const auto& d : defs) {
    if (d.offset < next) return false;
    next = static_cast<std::uint32_t>(d.offset) + word_count(d.type);
  }
  return next <= block;
}
static_assert(well_formed(kGateway, kGatewayBlockSize));
static_assert(well_formed(kBus, kBusStride));
static_assert(well_formed(kController, kControllerStride));
static_assert(well_formed(kDevice, kDeviceStride));

void csv_field(std::string& out, const char* text) {
  const std::string_view s(text);
  if (s.find_first_of(",\"\r\n") == std::string_view::npos) {
    out += s;
    return;
  }
  out += '"';
  for (const char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

void append_rows(std::vector<MapRow>& rows, std::span<const RegisterDef> defs, std::uint16_t base,
                 const std::string& prefix) {
  for (const RegisterDef& d : defs) {
    rows.push_back(MapRow{static_cast<std::uint16_t>(base + d.offset), prefix + d.name, &d});
  }
}

}  // namespace

const char* type_name(RegType t) noexcept {
  switch (t) {
    case RegType::kU16: return "uint16";
    case RegType::kI16: return "int16";
    case RegType::kU32: return "uint32";
    case RegType::kI32: return "int32";
  }
  return "?";
}

const char* access_name(Access a) noexcept { return a == Access::kRead ? "R" : "RW"; }

std::span<const RegisterDef> gateway_registers() noexcept { return kGateway; }
std::span<const RegisterDef> bus_registers() noexcept { return kBus; }
std::span<const RegisterDef> controller_registers() noexcept { return kController; }
std::span<const RegisterDef> device_registers() noexcept { return kDevice; }

std::vector<MapRow> map_rows(std::uint16_t buses, std::uint16_t slots) {
  if (buses > kMaxBuses) buses = kMaxBuses;
  if (slots > kMaxDeviceSlots) slots = kMaxDeviceSlots;
  std::vector<MapRow> rows;
  append_rows(rows, kGateway, kGatewayBase, "gateway.");
  for (std::uint16_t b = 0; b < buses; ++b) {
    append_rows(rows, kBus, bus_base(b), "bus[" + std::to_string(b) + "].");
  }
  for (std::uint16_t b = 0; b < buses; ++b) {
    append_rows(rows, kController, controller_base(b), "controller[" + std::to_string(b) + "].");
  }
  for (std::uint16_t n = 0; n < slots; ++n) {
    append_rows(rows, kDevice, device_base(n), "device[" + std::to_string(n) + "].");
  }
  return rows;
}

std::string map_csv(std::uint16_t buses, std::uint16_t slots) {
  std::string out = "address,name,type,unit,scale,access,description\r\n";
  for (const MapRow& row : map_rows(buses, slots)) {
    out += std::to_string(row.address);
    out += ',';
    out += row.name;
    out += ',';
    out += type_name(row.def->type);
    out += ',';
    csv_field(out, row.def->unit);
    out += ',';
    std::array<char, 32> num{};
    const auto res = std::to_chars(num.data(), num.data() + num.size(), row.def->scale);
    out.append(num.data(), res.ptr);
    out += ',';
    out += access_name(row.def->access);
    out += ',';
    csv_field(out, row.def->description);
    out += "\r\n";
  }
  return out;
}

}  // namespace cobridge::modbus
