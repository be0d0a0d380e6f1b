#include "sparkplug_metrics.hpp"

#include <array>

namespace cobridge::mqtt {
namespace {

using M = DeviceMetric;
using T = DataType;

constexpr std::array<MetricDef, 13> kProcess = {{
    {M::kPosition, "Position", T::kInt64, "counts", "0x6004 position value (TPDO)"},
    {M::kPositionEng, "Position/Engineering", T::kDouble, "*", "0x6004 scaled by the gateway's configured scale"},
    {M::kSpeed, "Speed", T::kInt32, "", "0x6030 speed value (TPDO)"},
    {M::kCamState, "CAM State", T::kUInt8, "", "0x6300/1 CAM state register (TPDO)"},
    {M::kWorkAreaState, "Work Area State", T::kUInt8, "", "0x6400/1 work area state register (TPDO)"},
    {M::kAlarms, "Alarms", T::kUInt16, "", "0x6503 alarms (TPDO)"},
    {M::kWarnings, "Warnings", T::kUInt16, "", "0x6505 warnings (TPDO)"},
    {M::kTemperature, "Temperature", T::kFloat, "degC", "device temperature (TPDO, 0.1 degC)"},
    {M::kVoltage, "Supply Voltage", T::kFloat, "V", "supply voltage (TPDO, 0.1 V)"},
    {M::kNmtState, "NMT State", T::kUInt8, "", "heartbeat state byte (CiA 301 7.2.8.3.2)"},
    {M::kStale, "Stale", T::kBoolean, "", "gateway: values older than the configured max age"},
    {M::kEmcyCode, "EMCY/Error Code", T::kUInt16, "", "EMCY frame bytes 0..1 (CiA 301 7.2.7)"},
    {M::kEmcyRegister, "EMCY/Error Register", T::kUInt8, "", "EMCY frame byte 2 (0x1001)"},
}};

constexpr std::array<MetricDef, 6> kCommand = {{
    {M::kCmdPreset, "Command/Preset", T::kInt64, "counts", "DCMD: preset the position (0x6003 / 0x6010)"},
    {M::kCmdNmtReset, "Command/NMT Reset", T::kBoolean, "", "DCMD: true = NMT reset node (CiA 301 7.2.8.3.1.1)"},
    {M::kCmdStore, "Command/Store", T::kBoolean, "", "DCMD: true = store parameters (0x1010)"},
    {M::kCmdClient, "Command/Client", T::kString, "", "DCMD: who sends it (required); DDATA: who asked"},
    {M::kCmdResult, "Command/Result", T::kString, "", "DDATA: a command's outcome or refusal, in words"},
    {M::kCmdResultCode, "Command/Result Code", T::kInt32, "", "DDATA: 0 done, 1..8 daemon status, 16.. refusal"},
}};

constexpr std::array<MetricDef, 8> kIdentity = {{
    {M::kVendorId, "Properties/Vendor ID", T::kUInt32, "", "0x1018/1"},
    {M::kProductCode, "Properties/Product Code", T::kUInt32, "", "0x1018/2"},
    {M::kRevision, "Properties/Revision", T::kUInt32, "", "0x1018/3"},
    {M::kSerial, "Properties/Serial Number", T::kUInt32, "", "0x1018/4"},
    {M::kModel, "Properties/Model", T::kString, "", "device description (EDS) product name"},
    {M::kFamily, "Properties/Family", T::kString, "", "device description family"},
    {M::kNodeId, "Properties/Node ID", T::kUInt8, "", "CANopen node-ID"},
    {M::kBus, "Properties/Bus", T::kString, "", "configured bus name"},
}};

}  // namespace

std::span<const MetricDef> process_metrics() noexcept { return kProcess; }
std::span<const MetricDef> command_metrics() noexcept { return kCommand; }
std::span<const MetricDef> identity_metrics() noexcept { return kIdentity; }

const MetricDef* find_metric(DeviceMetric id) noexcept {
  for (const auto& d : kProcess)
    if (d.id == id) return &d;
  for (const auto& d : kCommand)
    if (d.id == id) return &d;
  for (const auto& d : kIdentity)
    if (d.id == id) return &d;
  return nullptr;
}

std::size_t process_index(DeviceMetric id) noexcept { return static_cast<std::size_t>(id) - 1u; }

std::uint32_t MetricSets::for_device(std::string_view name) const noexcept {
  std::uint32_t any = kAll;
  for (const auto& [device, mask] : sets) {
    if (device == name) return mask;
    if (device == "*") any = mask;
  }
  return any;
}

namespace {

// Appends one reading when there is room.
class Out {
 public:
  explicit Out(std::span<Reading> out) noexcept : out_(out) {}
  void add(DeviceMetric id, std::int64_t i) noexcept { put(id, Scalar{i, 0.0}); }
  void add_real(DeviceMetric id, double d) noexcept { put(id, Scalar{0, d}); }
  [[nodiscard]] std::size_t count() const noexcept { return n_; }

 private:
  void put(DeviceMetric id, Scalar v) noexcept {
    if (n_ < out_.size()) out_[n_++] = Reading{id, v};
  }
  std::span<Reading> out_;
  std::size_t n_ = 0;
};

void extract_process(const cobridge_sample& s, Out& o) noexcept {
  const unsigned v = s.valid;
  if ((v & COBRIDGE_VALID_POSITION) != 0) o.add(M::kPosition, s.position);
  if ((v & COBRIDGE_VALID_POSITION_ENG) != 0) o.add_real(M::kPositionEng, s.position_eng);
  if ((v & COBRIDGE_VALID_SPEED) != 0) o.add(M::kSpeed, s.speed);
  if ((v & COBRIDGE_VALID_CAM_STATE) != 0) o.add(M::kCamState, s.cam_state);
  if ((v & COBRIDGE_VALID_WORK_AREA_STATE) != 0) o.add(M::kWorkAreaState, s.work_area_state);
  if ((v & COBRIDGE_VALID_ALARMS) != 0) o.add(M::kAlarms, s.alarms);
  if ((v & COBRIDGE_VALID_WARNINGS) != 0) o.add(M::kWarnings, s.warnings);
  if ((v & COBRIDGE_VALID_TEMPERATURE) != 0) o.add_real(M::kTemperature, s.temperature_dC / 10.0);
  if ((v & COBRIDGE_VALID_VOLTAGE) != 0) o.add_real(M::kVoltage, s.voltage_dV / 10.0);
}

}  // namespace

std::size_t extract(const cobridge_sample& s, std::span<Reading> out) noexcept {
  Out o(out);
  switch (s.kind) {
    case COBRIDGE_SAMPLE_TPDO:
      extract_process(s, o);
      break;
    case COBRIDGE_SAMPLE_EMCY:
      if ((s.valid & COBRIDGE_VALID_EMCY) != 0) {
        o.add(M::kEmcyCode, s.emcy_code);
        o.add(M::kEmcyRegister, s.emcy_register);
      }
      break;
    case COBRIDGE_SAMPLE_HEARTBEAT:
    case COBRIDGE_SAMPLE_NMT_STATE:
      if ((s.valid & COBRIDGE_VALID_NMT_STATE) != 0) o.add(M::kNmtState, s.nmt_state);
      break;
    case COBRIDGE_SAMPLE_STATUS:
      if ((s.valid & COBRIDGE_VALID_STATUS) != 0) o.add(M::kStale, s.stale != 0 ? 1 : 0);
      break;
    default:
      break;
  }
  return o.count();
}

}  // namespace cobridge::mqtt
