// The CANopen runtime every simulated family shares: power, NMT slave, SDO
// server, LSS slave, heartbeat and node guarding, SYNC, TPDOs, the storage
// commands and the 1 ms measuring cycle. What a family adds lives in
// family_*.cpp (see sim_device_impl.hpp).
#include "device/sim_device.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <chrono>

#include "canopen/cob_id.hpp"
#include "canopen/sync.hpp"
#include "families/ifm_rm.hpp"
#include "device/od_builder.hpp"
#include "device/sim_device_impl.hpp"
#include "device/storage.hpp"

namespace cobridge::sim {

namespace cob = canopen::cob;

namespace {

using namespace std::chrono_literals;
using canopen::NmtState;

constexpr std::uint16_t kErrorRegister = 0x1001;
constexpr std::uint16_t kStatusRegister = 0x1002;
constexpr std::uint16_t kCobIdSync = 0x1005;
constexpr std::uint16_t kGuardTime = 0x100C;
constexpr std::uint16_t kLifeTimeFactor = 0x100D;
constexpr std::uint16_t kStore = 0x1010;
constexpr std::uint16_t kRestore = 0x1011;
constexpr std::uint16_t kHeartbeatTime = 0x1017;
constexpr std::uint16_t kIdentity = 0x1018;
constexpr std::uint16_t kTpdoComm = 0x1800;
constexpr std::uint16_t kTpdoMap = 0x1A00;
constexpr std::uint16_t kNmtStartup = 0x1F80;
constexpr std::uint32_t kAutostartBit = 0x08;  // J§1.3.1, E§4.1: bit 3, not CiA 302's bit 2
constexpr auto kMeasuringCycle = 1ms;          // J§1.2.5, E§3.3

bool is_writable(const canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub) {
  const auto info = od.info(index, sub);
  return info && info->access == canopen::Access::kRw;
}

canopen::LssSlaveFeatures lss_features(const DeviceSpec& spec, FamilyId family) {
  LssProfile p = spec.lss;
  if (p == LssProfile::family_default) p = family == FamilyId::novotechnik_rotary ? LssProfile::v1 : LssProfile::v3;
  canopen::LssSlaveFeatures f =
      p == LssProfile::v1 ? canopen::LssSlaveFeatures::rotary_j() : canopen::LssSlaveFeatures::multiturn_e();
  if (!spec.lss_fastscan) f.fastscan = false;
  f.node_id_assignment = spec.assign;
  f.lose_node_id_requests = spec.lose_configure;
  // ifm: CiA table rates it can run at (F§7.4 minus 100 kbit/s, which the
  // CiA 305 table does not have): 1000, 800, 500, 250, 125, 50, 20.
  if (family == FamilyId::ifm_rm) f.bit_timings = 0x00DF;
  return f;
}

}  // namespace

// ---------------------------------------------------------------------------
// Small shared helpers

std::uint32_t set_raw(canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub,
                      std::uint64_t raw) noexcept {
  const auto info = od.info(index, sub);
  if (!info) return canopen::od_abort::kObjectDoesNotExist;
  using canopen::DataType;
  switch (info->type) {
    case DataType::kInteger8: return od.set_i8(index, sub, static_cast<std::int8_t>(static_cast<std::uint8_t>(raw)));
    case DataType::kInteger16:
      return od.set_i16(index, sub, static_cast<std::int16_t>(static_cast<std::uint16_t>(raw)));
    case DataType::kInteger32:
      return od.set_i32(index, sub, static_cast<std::int32_t>(static_cast<std::uint32_t>(raw)));
    case DataType::kInteger64: return od.set_i64(index, sub, static_cast<std::int64_t>(raw));
    case DataType::kReal32: return od.set_f32(index, sub, std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
    default: break;
  }
  if (info->is_string) return canopen::od_abort::kLengthMismatch;
  const std::uint64_t mask = info->size >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8U * info->size)) - 1U;
  return od.set_u64(index, sub, raw & mask);
}

std::optional<std::uint8_t> lss_index_for_kbit(std::uint16_t kbit) noexcept {
  for (std::uint8_t i = 0; i <= 8; ++i)
    if (canopen::lss_bit_rate_kbit(i) == kbit && kbit != 0) return i;
  return std::nullopt;
}

std::uint16_t ifm_kbit(std::uint8_t index) noexcept {
  const auto& rates = device::families::kIfmBitRates;  // F§7.4 0x3001
  return index < rates.size() ? rates[index] : 0;
}

std::optional<std::uint8_t> ifm_index_for_kbit(std::uint16_t kbit) noexcept {
  for (std::uint8_t i = 0; i < 8; ++i)
    if (ifm_kbit(i) == kbit) return i;
  return std::nullopt;
}

namespace {
// The node-ID object's value for `node` and back (F§7.4: ifm holds node-ID - 1,
// keeping FFh, unconfigured, as FFh; Novotechnik the node-ID itself).
std::uint8_t node_value(const device::families::Addressing& a, std::uint8_t node) noexcept {
  return node == cob::kNodeIdUnconfigured ? node : static_cast<std::uint8_t>(node - a.node_id_offset);
}
std::uint8_t node_of_value(const device::families::Addressing& a, std::uint64_t raw) noexcept {
  if (a.node_id_offset == 0) return static_cast<std::uint8_t>(raw);
  return raw >= 0x7F ? cob::kNodeIdUnconfigured : static_cast<std::uint8_t>(raw + a.node_id_offset);
}
}  // namespace

// ---------------------------------------------------------------------------
// Construction

SimDevice::Impl::Impl(DeviceSpec spec_in, const device::DeviceDescription& description, can::FrameSink& sink,
                      std::filesystem::path state_dir)
    : spec(std::move(spec_in)),
      model(*spec.model),
      family(spec.model->family),
      desc(description),
      bus(sink),
      nv_file(state_dir.empty() ? std::filesystem::path{}
                                : state_dir / fmt::format("{}-{}.nv", family_name(family), spec.serial)),
      nv(nv_file) {
  tx.device = this;
  late_lss = LateAnswers(spec.late_lss, std::chrono::milliseconds(spec.late_lss_ms));
  factory_node = spec.node_id == 0 ? model.factory_node_id : spec.node_id;
  factory_kbit = spec.bitrate_kbit != 0 ? spec.bitrate_kbit : model.factory_bitrate_kbit;
  if (const device::ObjectDesc* ch = desc.find(0x6020, 0); ch != nullptr && family == FamilyId::novotechnik_rotary)
    channels = static_cast<std::uint8_t>(std::clamp<std::uint64_t>(ch->default_for_node(0).value_or(1), 1, 2));
  guard.set_callback([this](canopen::GuardResponder::EventKind kind, TimePoint) {
    family_life_guarding(kind == canopen::GuardResponder::EventKind::life_guarding_lost);
  });
  family_factory();
}

bool SimDevice::Impl::emcy_thunk(void* context, const can::Frame& frame) noexcept {
  return static_cast<Impl*>(context)->send(frame, TruthRecord::Kind::emcy);
}

bool SimDevice::Impl::Tx::send(const can::Frame& frame) noexcept {
  const bool lss_answer = frame.id == canopen::cob::kLssSlaveToMaster;
  if (lss_answer && device->powered && device->late_lss.hold(frame, device->now_cache)) return true;
  return device->send(frame, lss_answer ? TruthRecord::Kind::lss : TruthRecord::Kind::sdo);
}

// ---------------------------------------------------------------------------
// Transmit path and truth records

bool SimDevice::Impl::send(const can::Frame& frame, TruthRecord::Kind kind, std::uint8_t pdo) noexcept {
  // A bus-off controller takes no part in the bus (can_controller.cpp).
  if (!powered || silent || can_state == CanControllerState::bus_off) return false;
  const bool ok = bus.send(frame);
  if (ok && truth) {
    try {
      emit_truth(frame, kind, pdo);
    } catch (...) {
      // A failing observer must not take the device down; the frame is out.
    }
  }
  return ok;
}

void SimDevice::Impl::emit_truth(const can::Frame& frame, TruthRecord::Kind kind, std::uint8_t pdo) const {
  TruthRecord r;
  r.serial = spec.serial;
  r.node_id = active_node;
  r.frame = frame;
  r.kind = kind;
  r.pdo = pdo;
  if (kind == TruthRecord::Kind::emcy && frame.len >= 2)
    r.emcy_code = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
  if (kind == TruthRecord::Kind::tpdo && pdo >= 1 && pdo <= 2 && layout_ok[pdo - 1U]) {
    const canopen::PdoLayout& l = layout[pdo - 1U];
    const std::span<const std::uint8_t, 8> data(frame.data);
    for (std::size_t i = 0; i < l.field_count(); ++i) {
      const canopen::PdoField& f = l.field(i);
      const std::int64_t v = l.value(data, i);
      const bool position = (f.index == 0x6020 && f.sub == 1) || (f.index == 0x6004 && f.sub == 0);
      if (position && !r.has_position) {
        r.has_position = true;
        r.position = v;
      } else if (f.index == 0x6030 && f.sub == 1) {
        r.has_speed = true;
        r.speed = static_cast<std::int32_t>(v);
      } else if (f.index == 0x6300 && f.sub == 1) {
        r.cam_state = static_cast<std::int16_t>(v);
      } else if (f.index == 0x6400 && f.sub == 1) {
        r.work_area_state = static_cast<std::int16_t>(v);
      }
    }
  }
  truth(r);
}

void SimDevice::Impl::send_emcy(const canopen::Emcy& e, device::families::EmcyLevel level) noexcept {
  if (!nmt.allows(canopen::NmtService::emcy)) return;
  (void)emcy.send(e, level, now_cache);
}

// ---------------------------------------------------------------------------
// Object dictionary

std::uint64_t SimDevice::Impl::factory_value(const device::ObjectDesc& e, std::uint8_t node) const noexcept {
  const std::uint32_t key = NvImage::key(e.index, e.sub);
  if (legacy_kill && model.legacy_rsx_rfx) {
    // J§1.10 / J§1.3.3 0x2001: RSX/RFX 'kill' also resets the custom factory
    // parameters, the bit rate to 250 kbit/s whatever the ordering code said.
    if (e.index == 0x2000 && e.sub == 0) return 0x7F;
    if (e.index == 0x2001 && e.sub == 0) return 250;
  }
  if (const auto it = factory.find(key); it != factory.end()) return it->second;
  return eds_default_raw(e, node == cob::kNodeIdUnconfigured ? 0 : node);
}

std::error_code SimDevice::Impl::build_od(std::string& message) {
  canopen::ObjectDictionary::Options options;
  od = std::make_unique<canopen::ObjectDictionary>(options);
  const std::uint8_t node = active_node;
  auto adjust = [this, node](canopen::EntryDef& def) {
    // Values the EDS leaves open come from the factory table; then the
    // family may change what the manual contradicts.
    if (const auto it = factory.find(NvImage::key(def.index, def.sub)); it != factory.end()) {
      const device::ObjectDesc* e = desc.find(def.index, def.sub);
      if (e != nullptr && !is_string_type(e->data_type)) {
        const canopen::Number n = canopen::Number(it->second);
        def.value = n;
        if (device::is_signed_integer(e->data_type)) {
          const std::uint32_t w = device::bit_size(e->data_type);
          const std::uint64_t sign = std::uint64_t{1} << (w - 1U);
          const std::uint64_t v = it->second & ((w >= 64) ? ~std::uint64_t{0} : ((std::uint64_t{1} << w) - 1U));
          def.value = canopen::Number(static_cast<std::int64_t>(v ^ sign) - static_cast<std::int64_t>(sign));
        }
      }
    }
    (void)node;
    // A factory value outside the EDS limits (node-ID FFh = unconfigured in
    // 0x2000, limits 1..127) goes in through the typed setter afterwards.
    auto outside = [&def](const std::optional<canopen::Number>& lim, bool is_low) {
      if (!lim) return false;
      if (def.value.kind() == canopen::Number::Kind::kSigned || lim->kind() == canopen::Number::Kind::kSigned) {
        const std::int64_t v = def.value.kind() == canopen::Number::Kind::kSigned
                                   ? def.value.as_signed() : static_cast<std::int64_t>(def.value.as_unsigned());
        const std::int64_t l = lim->kind() == canopen::Number::Kind::kSigned
                                   ? lim->as_signed() : static_cast<std::int64_t>(lim->as_unsigned());
        return is_low ? v < l : v > l;
      }
      return is_low ? def.value.as_unsigned() < lim->as_unsigned() : def.value.as_unsigned() > lim->as_unsigned();
    };
    if (outside(def.low, true) || outside(def.high, false)) {
      if (const device::ObjectDesc* e = desc.find(def.index, def.sub); e != nullptr && def.low)
        def.value = e->default_value.kind == device::EdsValue::Kind::kNone ? *def.low
                                                                            : canopen::Number(eds_default_raw(*e, 0));
    }
    family_adjust(def);
  };
  if (const std::error_code ec = build_object_dictionary(desc, node, *od, message, adjust)) return ec;
  family_extras();
  // Identity and names: per device, not in the EDS (J§1.2.1, E§4.1, F§7.3).
  (void)od->set_u32(kIdentity, 4, spec.serial);
  if (spec.vendor) (void)od->set_u32(kIdentity, 1, *spec.vendor);
  if (spec.product) (void)od->set_u32(kIdentity, 2, *spec.product);
  if (spec.revision) (void)od->set_u32(kIdentity, 3, *spec.revision);
  if (od->contains(0x650B, 0)) (void)od->set_u32(0x650B, 0, spec.serial);
  if (od->contains(0x1008, 0)) {
    const auto current = od->get_string(0x1008, 0);
    if (!current || current->empty()) (void)od->set_string(0x1008, 0, model.name);
  }
  if (od->contains(0x1009, 0)) (void)od->set_string(0x1009, 0, family == FamilyId::ifm_rm ? "1.0" : "V 1.00");
  if (od->contains(0x100A, 0)) (void)od->set_string(0x100A, 0, family == FamilyId::ifm_rm ? "1.0" : "V 1.03");
  install_hooks();
  return {};
}

void SimDevice::Impl::install_hooks() {
  canopen::Hooks hooks;
  hooks.on_read = [this](std::uint16_t index, std::uint8_t sub) { return on_read(index, sub); };
  hooks.on_write = [this](const canopen::WriteRequest& req) { return on_write(req); };
  hooks.after_write = [this](std::uint16_t index, std::uint8_t sub) { after_write(index, sub); };
  std::uint16_t previous = 0;
  bool first = true;
  for (const device::ObjectDesc& e : desc.entries) {
    if (!first && e.index == previous) continue;
    first = false;
    previous = e.index;
    (void)od->set_hooks(e.index, hooks);
  }
  if (family == FamilyId::novotechnik_multiturn && od->contains(0x6020, 1)) (void)od->set_hooks(0x6020, hooks);
}

template <typename Select>
void SimDevice::Impl::load_parameters(Select select, const NvImage* image) {
  for (const device::ObjectDesc& e : desc.entries) {
    if (is_string_type(e.data_type)) continue;
    const bool param = is_writable(*od, e.index, e.sub);
    if (!param && !e.default_value.plus_node_id) continue;
    if (!select(e)) continue;
    std::uint64_t v = factory_value(e, active_node);
    if (image != nullptr && param)
      if (const auto stored = image->get(e.index, e.sub)) v = *stored;
    (void)set_raw(*od, e.index, e.sub, v);
  }
  if (family == FamilyId::ifm_rm) ifm_mirror_event_timer();
}

std::error_code SimDevice::Impl::persist(std::string& message) const { return nv.save(nv_data, message); }

std::uint32_t SimDevice::Impl::save(std::uint8_t store_sub) {
  for (const device::ObjectDesc& e : desc.entries) {
    if (is_string_type(e.data_type) || !is_writable(*od, e.index, e.sub)) continue;
    const Coverage c = store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub);
    if (c == Coverage::none) continue;
    if (c == Coverage::default_value) {
      nv_data.params.erase(e.index, e.sub);
      continue;
    }
    // ifm 'load' then 'save': the factory settings reach the EEPROM (F§6.3.5).
    const std::uint64_t v =
        ifm_defaults_pending ? factory_value(e, active_node) : od->get_raw(e.index, e.sub).value_or(0);
    // A $NODEID value equal to its default is left to the default, so it
    // follows a later node-ID change as the predefined connection set does.
    if (e.default_value.plus_node_id && v == eds_default_raw(e, active_node))
      nv_data.params.erase(e.index, e.sub);
    else
      nv_data.params.set(e.index, e.sub, v);
  }
  // The preset's effect is an offset the device keeps with it (CiA 406
  // 0x6509); without it a stored preset would mean nothing after power-up.
  const std::uint16_t preset_index = family == FamilyId::novotechnik_rotary ? 0x6010 : 0x6003;
  const auto preset_sub = static_cast<std::uint8_t>(family == FamilyId::novotechnik_rotary ? 1 : 0);
  if (store_coverage(family, model.legacy_rsx_rfx, store_sub, preset_index, preset_sub) == Coverage::value) {
    for (std::size_t ch = 0; ch < channels; ++ch)
      nv_data.params.set(kOffsetKeyIndex, static_cast<std::uint8_t>(kOffsetKeySub + ch),
                         static_cast<std::uint64_t>(ifm_defaults_pending ? 0 : encoder.offset(static_cast<int>(ch))));
  }
  ifm_defaults_pending = false;
  std::string message;
  if (persist(message)) return canopen::od_abort::kCannotStore;  // J/E: "data transfer error"
  return 0;
}

std::uint32_t SimDevice::Impl::load(std::uint8_t store_sub) {
  if (family == FamilyId::ifm_rm) {
    // F§6.3.5: factory settings, active only after a reset; EEPROM untouched.
    ifm_defaults_pending = true;
    return 0;
  }
  // Digest D: Novotechnik 'load' reverts RAM to the last saved image.
  const NvImage& image = nv_data.params;
  load_parameters(
      [&](const device::ObjectDesc& e) {
        return store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub) != Coverage::none;
      },
      &image);
  restore_offsets(&image);
  return 0;
}

std::uint32_t SimDevice::Impl::kill(std::uint8_t store_sub) {
  auto covered = [&](const device::ObjectDesc& e) {
    return store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub) != Coverage::none;
  };
  for (const device::ObjectDesc& e : desc.entries)
    if (covered(e)) nv_data.params.erase(e.index, e.sub);
  legacy_kill = true;
  load_parameters(covered, nullptr);
  legacy_kill = false;
  const std::uint16_t preset_index = family == FamilyId::novotechnik_rotary ? 0x6010 : 0x6003;
  const auto preset_sub = static_cast<std::uint8_t>(family == FamilyId::novotechnik_rotary ? 1 : 0);
  if (store_coverage(family, model.legacy_rsx_rfx, store_sub, preset_index, preset_sub) != Coverage::none) {
    for (std::size_t ch = 0; ch < channels; ++ch)
      nv_data.params.erase(kOffsetKeyIndex, static_cast<std::uint8_t>(kOffsetKeySub + ch));
    restore_offsets(nullptr);
  }
  std::string message;
  if (persist(message)) return canopen::od_abort::kCannotStore;
  return 0;
}

std::uint8_t SimDevice::Impl::node_from_od() const noexcept {
  const auto& a = family_facts(family).addressing;
  return node_of_value(a, od->get_u8(a.node_id_index, 0).value_or(node_value(a, factory_node)));
}

std::uint16_t SimDevice::Impl::kbit_from_od() const noexcept {
  if (family == FamilyId::ifm_rm) return ifm_kbit(od->get_u8(0x3001, 0).value_or(3));
  return od->get_u16(0x2001, 0).value_or(factory_kbit);
}

void SimDevice::Impl::node_to_od(std::uint8_t node) noexcept {
  const auto& a = family_facts(family).addressing;
  (void)od->set_u8(a.node_id_index, 0, node_value(a, node));
}

void SimDevice::Impl::kbit_to_od(std::uint16_t kbit) noexcept {
  if (family == FamilyId::ifm_rm) {
    if (const auto i = ifm_index_for_kbit(kbit)) (void)od->set_u8(0x3001, 0, *i);
  } else {
    (void)od->set_u16(0x2001, 0, kbit);
  }
}

bool SimDevice::Impl::scaling_active() const noexcept {
  const std::uint64_t op = od->get_raw(0x6000, 0).value_or(0);
  const bool bit = (op & 0x04U) != 0;
  // J§1.4.1 and F§7.5 SFC: 1 = on. E§5.3 as printed: 0 = on (digest D).
  return family == FamilyId::novotechnik_multiturn ? !bit : bit;
}

std::int64_t SimDevice::Impl::get_int(std::uint16_t index, std::uint8_t sub) const noexcept {
  const auto info = od->info(index, sub);
  if (!info || info->is_string) return 0;
  const std::uint64_t raw = od->get_raw(index, sub).value_or(0);
  using canopen::DataType;
  switch (info->type) {
    case DataType::kInteger8: return static_cast<std::int8_t>(static_cast<std::uint8_t>(raw));
    case DataType::kInteger16: return static_cast<std::int16_t>(static_cast<std::uint16_t>(raw));
    case DataType::kInteger32: return static_cast<std::int32_t>(static_cast<std::uint32_t>(raw));
    case DataType::kInteger64: return static_cast<std::int64_t>(raw);
    default: return static_cast<std::int64_t>(raw);
  }
}

void SimDevice::Impl::configure_encoder() {
  if (!od) return;
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const auto s = static_cast<std::uint8_t>(ch + 1);
    ChannelConfig c;
    c.operating_parameter = static_cast<std::uint16_t>(od->get_raw(0x6000, 0).value_or(0));
    c.per_rev = static_cast<std::uint32_t>(od->get_raw(0x6001, 0).value_or(0));
    c.total = static_cast<std::uint32_t>(od->get_raw(0x6002, 0).value_or(0));
    c.position_filter = od->get_u8(0x2010, 1).value_or(0);
    c.speed_integration_ms = od->get_u16(0x6031, 2).value_or(1);
    if (family == FamilyId::ifm_rm) {
      const std::uint16_t op = od->get_u16(0x2100, 0).value_or(0);
      c.speed_enabled = od->get_u8(0x3010, 1).value_or(0) != 0;
      c.speed_mode = od->get_u8(0x3010, 2).value_or(0);
      c.limit_min_enabled = (op & 0x02U) != 0;
      c.limit_max_enabled = (op & 0x04U) != 0;
      c.limit_min = od->get_u32(0x2104, 0).value_or(0);
      c.limit_max = od->get_u32(0x2105, 0).value_or(0);
    }
    c.cams.count = family == FamilyId::ifm_rm ? 8 : 4;
    c.cams.enable = od->get_u8(0x6301, s).value_or(0);
    c.cams.polarity = od->get_u8(0x6302, s).value_or(0);
    for (std::uint8_t k = 0; k < c.cams.count; ++k) {
      c.cams.low[k] = get_int(static_cast<std::uint16_t>(0x6310 + k), s);
      c.cams.high[k] = get_int(static_cast<std::uint16_t>(0x6320 + k), s);
      c.cams.hysteresis[k] = get_int(static_cast<std::uint16_t>(0x6330 + k), s);
    }
    c.has_work_area = od->contains(0x6400, s);
    c.work_area.low = get_int(0x6401, s);
    c.work_area.high = get_int(0x6402, s);
    if (family == FamilyId::novotechnik_rotary) {
      // J§1.4.6.1: bit 0 for "position <= preset or >= sensor length".
      c.work_area.range_min = get_int(0x6010, s);
      c.work_area.range_max = c.total != 0 ? c.total : 0x4000;
    } else {
      c.work_area.range_min = get_int(0x650A, 2);
      c.work_area.range_max = get_int(0x650A, 3);
    }
    encoder.configure(static_cast<int>(ch), c);
  }
}

void SimDevice::Impl::restore_offsets(const NvImage* image) {
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const auto key_sub = static_cast<std::uint8_t>(kOffsetKeySub + ch);
    const std::uint16_t preset_index = family == FamilyId::novotechnik_rotary ? 0x6010 : 0x6003;
    const auto preset_sub = static_cast<std::uint8_t>(family == FamilyId::novotechnik_rotary ? ch + 1 : 0);
    std::int64_t off = 0;
    if (image != nullptr)
      if (const auto v = image->get(kOffsetKeyIndex, key_sub)) off = static_cast<std::int64_t>(*v);
    encoder.restore_offset(static_cast<int>(ch), off, get_int(preset_index, preset_sub));
  }
}

// ---------------------------------------------------------------------------
// SDO hooks shared by all families

std::uint32_t SimDevice::Impl::on_read(std::uint16_t index, std::uint8_t sub) {
  (void)index;
  (void)sub;
  return 0;
}

std::uint32_t SimDevice::Impl::on_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::uint32_t value = static_cast<std::uint32_t>(req.as_unsigned());
  if ((req.index == kStore || req.index == kRestore) && req.sub >= 1) {
    // J§1.10, E§11 (and F§6.1.1 for ifm): signatures only in pre-operational.
    if (!pre_operational()) return kCannotStoreDeviceState;
    const std::uint8_t subs = store_sub_count(family);
    if (req.index == kStore) {
      if (value == kSignatureSave) return req.sub <= subs ? save(req.sub) : 0;  // sub 5: "do not use", no-op
      if (value == kSignatureKill && family != FamilyId::ifm_rm && req.sub <= subs) return kill(req.sub);
      return kCannotStore;
    }
    if (value == kSignatureLoad && req.sub <= subs) {
      const std::uint32_t r = load(req.sub);
      if (r == 0) {
        pending_node = node_from_od();
        pending_kbit = kbit_from_od();
      }
      return r;
    }
    return kCannotStore;
  }
  if (req.index == kTpdoComm || req.index == kTpdoComm + 1) return check_tpdo_write(req);
  if (req.index == kTpdoMap || req.index == kTpdoMap + 1) return check_mapping_write(req);
  return family_on_write(req);
}

void SimDevice::Impl::after_write(std::uint16_t index, std::uint8_t sub) {
  const TimePoint now = now_cache;
  if ((index == kStore || index == kRestore) && sub >= 1) {
    // The signature objects read back as the manual prints them (0; digest A.9.22).
    (void)od->set_u32(index, sub, 0);
    if (index == kRestore || index == kStore) {
      configure_encoder();
      if (family == FamilyId::novotechnik_multiturn) condition_configure();
      for (std::size_t i = 0; i < 2; ++i) reconfigure_tpdo(i, now);
      configure_guard();
      restart_heartbeat(now);
    }
    return;
  }
  switch (index) {
    case kTpdoComm: case kTpdoComm + 1: case kTpdoMap: case kTpdoMap + 1:
      family_after_write(index, sub);  // ifm mirrors 0x1800/5 into 0x6200 / 0x2200
      reconfigure_tpdo(index & 1U, now);
      return;
    case kHeartbeatTime: restart_heartbeat(now); return;
    case kGuardTime: case kLifeTimeFactor: configure_guard(); return;
    case kNmtStartup: nmt.set_autostart((od->get_u32(kNmtStartup, 0).value_or(0) & kAutostartBit) != 0); return;
    case 0x2000: case 0x2001:
      if (family != FamilyId::ifm_rm) {
        pending_node = node_from_od();
        pending_kbit = kbit_from_od();
        return;
      }
      break;
    default: break;
  }
  family_after_write(index, sub);
  if ((index >= 0x6000 && index < 0x7000) || index == 0x2010 || index == 0x3010) configure_encoder();
  if (family == FamilyId::novotechnik_multiturn && index >= 0x2300 && index < 0x2400) condition_configure();
}

std::uint32_t SimDevice::Impl::check_tpdo_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::size_t i = req.index & 1U;
  const std::uint32_t v = static_cast<std::uint32_t>(req.as_unsigned());
  const std::uint32_t current = od->get_u32(req.index, 1).value_or(Tpdo::kInvalid);
  if (req.sub == 1) {
    // CiA 301 §7.5.2.35: 29-bit identifiers are not supported here, and the
    // identifier of a valid PDO cannot change (disable it first).
    if ((v & 0x20000000u) != 0 || (v & 0x1FFFF800u) != 0) return kValueRangeExceeded;
    const bool was_valid = (current & Tpdo::kInvalid) == 0;
    const bool stays_valid = (v & Tpdo::kInvalid) == 0;
    if (was_valid && stays_valid && (v & 0x7FFu) != (current & 0x7FFu)) return kValueRangeExceeded;
    if (stays_valid && !layout_ok[i] && od->get_u8(kTpdoMap + static_cast<std::uint16_t>(i), 0).value_or(0) != 0)
      return kCannotStoreDeviceState;
    return 0;
  }
  if (req.sub == 2) {
    const bool sync = v >= 1 && v <= 240;
    bool ok = false;
    if (family == FamilyId::ifm_rm) {
      ok = v == 0 || sync || v >= 252;  // F§7.3 transmission-type table
    } else if (i == 0) {
      ok = v == 0 || sync || v == 254 || v == 255;  // J§1.3.1, E§4.1
    } else {
      ok = v == 0 || sync;  // TPDO2: synchronous only
    }
    return ok ? 0 : kValueRangeExceeded;
  }
  return family_on_write(req);
}

std::uint32_t SimDevice::Impl::check_mapping_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::size_t i = req.index & 1U;
  const auto comm = static_cast<std::uint16_t>(kTpdoComm + i);
  // J§1.7.2 step 1 / E§8.2 step 1: the PDO must be disabled (bit 31); the
  // manuals list only 0x08000022 for a refusal of this kind. E also wants
  // pre-operational.
  if ((od->get_u32(comm, 1).value_or(0) & Tpdo::kInvalid) == 0) return kCannotStoreDeviceState;
  if (family == FamilyId::novotechnik_multiturn && !pre_operational()) return kCannotStoreDeviceState;
  const std::size_t max_entries = family == FamilyId::ifm_rm ? 2 : canopen::kNovotechnikMaxPdoEntries;
  if (req.sub == 0) {
    const std::uint64_t n = req.as_unsigned();
    if (n > max_entries) return 0x06040042;  // CiA 301: number / length of mapped objects exceeded
    std::array<std::uint32_t, 8> entries{};
    for (std::size_t k = 0; k < n; ++k)
      entries[k] = od->get_u32(req.index, static_cast<std::uint8_t>(k + 1)).value_or(0);
    const auto result = canopen::build_pdo_layout(std::span<const std::uint32_t>(entries.data(), n), {},
                                                  canopen::PdoLimits{max_entries, 64});
    if (!result.ok()) return canopen::sdo_abort_code(static_cast<canopen::PdoMapErrc>(result.error.value()));
    for (std::size_t k = 0; k < n; ++k)
      if (entries[k] == 0) return 0x06040041;
    return 0;
  }
  // CiA 301 §7.5.2.36 step 2: entries change only while sub 0 is 0.
  if (od->get_u8(req.index, 0).value_or(0) != 0) return kCannotStoreDeviceState;
  const std::uint32_t raw = static_cast<std::uint32_t>(req.as_unsigned());
  if (raw == 0) return 0;
  const auto e = canopen::PdoMapEntry::from_raw(raw);
  const auto info = od->info(e.index, e.sub);
  if (!info || !info->pdo_mappable || info->is_string || info->size * 8U != e.bits) return 0x06040041;
  return 0;
}

// ---------------------------------------------------------------------------
// Power, boot and resets

std::error_code SimDevice::Impl::power_on(TimePoint now) {
  if (powered) return {};
  now_cache = now;
  std::string message;
  if (const std::error_code ec = nv.load(nv_data, message)) return ec;

  // The node-ID the device boots with: what was stored, else the factory one.
  active_node = factory_node;
  const auto& addressing = family_facts(family).addressing;
  if (const auto stored = nv_data.params.get(addressing.node_id_index, 0))
    active_node = node_of_value(addressing, *stored);

  if (const std::error_code ec = build_od(message)) return ec;
  load_parameters([](const device::ObjectDesc&) { return true; }, &nv_data.params);
  if (!nv_data.params.get(addressing.node_id_index, 0)) node_to_od(factory_node);
  pending_node = active_node;
  active_kbit = pending_kbit = kbit_from_od();

  encoder.set_family(family, Resolution{static_cast<std::uint32_t>(od->get_raw(0x6501, 0).value_or(0x4000)),
                                        static_cast<std::uint32_t>(od->get_raw(0x6502, 0).value_or(1))});
  if (const std::error_code ec = encoder.set_motion(spec.motion, now)) return ec;

  canopen::SdoServerConfig sdo_config;
  sdo_config.segmented = spec.segmented_sdo;
  sdo = std::make_unique<canopen::SdoServer>(tx, *od, cob::valid_node_id(active_node) ? active_node : 1, sdo_config);
  if (spec.lss != LssProfile::none) lss.emplace(tx, identity_of(), active_node, lss_features(spec, family));
  if (lss) lss->set_store_handler([this](const canopen::LssSlave& s) { return lss_store(s); });
  emcy.attach(od.get(), &Impl::emcy_thunk, this);

  const bool novotechnik = family != FamilyId::ifm_rm;
  TpdoPolicy policy;
  policy.type0_off = novotechnik;
  policy.type255_every_cycle = novotechnik;
  policy.on_change = !novotechnik;
  policy.rtr = !novotechnik;
  for (auto& t : tpdo) t.set_policy(policy);
  tpdo_present = {true, family != FamilyId::ifm_rm || spec.ifm_c6};

  faults = 0;
  over_range_latched = under_range_latched = false;
  alarms = warnings = 0;
  status = 0;
  life_guarding_lost = false;
  can_state = CanControllerState::error_active;  // a fresh controller after power-up
  ifm_defaults_pending = false;
  reset_node_requested = false;
  guard = canopen::GuardResponder{};
  guard.set_callback([this](canopen::GuardResponder::EventKind kind, TimePoint) {
    family_life_guarding(kind == canopen::GuardResponder::EventKind::life_guarding_lost);
  });
  emcy.set_error_register(0);
  powered = true;
  first_measure = true;
  configure_encoder();
  restore_offsets(&nv_data.params);
  if (family == FamilyId::novotechnik_multiturn) condition_power_up(now);
  // The first measuring cycle runs before the boot-up, so the position
  // objects hold a real value from the first SDO read on.
  measure(now);
  next_measure = now + kMeasuringCycle;
  boot(now);
  return {};
}

void SimDevice::Impl::power_off() noexcept {
  powered = false;
  late_lss.clear();
  lss.reset();
  sdo.reset();
  emcy.attach(nullptr, nullptr, nullptr);
  od.reset();
  for (auto& t : tpdo) t.set_running(false, now_cache);
  layout_ok = {false, false};
  next_heartbeat = next_measure = canopen::kNever;
}

void SimDevice::Impl::boot(TimePoint now) {
  nmt.power_on();
  if (od->contains(kNmtStartup, 0))
    nmt.set_autostart((od->get_u32(kNmtStartup, 0).value_or(0) & kAutostartBit) != 0);
  const bool configured = cob::valid_node_id(active_node);
  sdo->set_enabled(configured);
  if (configured) sdo->set_node_id(active_node);
  guard.reset_communication();
  configure_guard();
  emcy.reset();
  for (std::size_t i = 0; i < 2; ++i) reconfigure_tpdo(i, now);
  if (!configured) {
    // CiA 305: without a node-ID the device waits in initialisation, silent
    // except for LSS, until a node-ID is configured.
    if (lss) lss->set_ignore(false);
    next_heartbeat = canopen::kNever;
    refresh_status();
    return;
  }
  const auto from = nmt.state();
  (void)nmt.complete_initialisation();
  send(canopen::make_boot_up(active_node), TruthRecord::Kind::boot_up);
  on_nmt_change(from, now);
  restart_heartbeat(now);
}

void SimDevice::Impl::reset_communication(TimePoint now) { reset_communication(now, &nv_data.params); }

void SimDevice::Impl::reset_communication(TimePoint now, const NvImage* image) {
  now_cache = now;
  active_node = pending_node;
  active_kbit = pending_kbit;
  // Communication area back to `image` (the stored one, or none = the
  // defaults), with the new node-ID in the predefined connection set.
  load_parameters([](const device::ObjectDesc& e) { return e.index >= 0x1000 && e.index < 0x2000; }, image);
  if (lss) {
    const canopen::LssSlaveFeatures f = lss->features();
    lss.emplace(tx, identity_of(), active_node, f);
    lss->set_store_handler([this](const canopen::LssSlave& s) { return lss_store(s); });
  }
  boot(now);
}

void SimDevice::Impl::reset_node(TimePoint now) {
  now_cache = now;
  // A pending node-ID / bit rate (SDO or LSS) survives into the restart and
  // becomes active (digest A.1, S.18).
  const std::uint8_t node = pending_node;
  const std::uint16_t kbit = pending_kbit;
  // ifm 'load' (F§6.3.5, F§7.3 0x1011): this reset activates the factory
  // settings without touching the EEPROM, so every stage of the reset below
  // (application and communication area, the preset offset) takes the
  // defaults, not the stored image.
  const NvImage* image = ifm_defaults_pending ? nullptr : &nv_data.params;
  ifm_defaults_pending = false;
  load_parameters([](const device::ObjectDesc&) { return true; }, image);
  if (family != FamilyId::ifm_rm || !nv_data.params.get(0x3000, 0)) {
    pending_node = node;
    pending_kbit = kbit;
  } else {
    pending_node = node_from_od();
    pending_kbit = kbit_from_od();
  }
  node_to_od(pending_node);
  kbit_to_od(pending_kbit);
  faults &= ~(fault_bit(FaultKind::over_range) | fault_bit(FaultKind::under_range));
  encoder.reset();
  configure_encoder();
  restore_offsets(image);
  measure(now);
  reset_communication(now, image);
}

// ---------------------------------------------------------------------------
// NMT, LSS, error control

void SimDevice::Impl::on_nmt_change(NmtState from, TimePoint now) {
  (void)from;
  const bool operational = nmt.state() == NmtState::operational;
  for (std::size_t i = 0; i < 2; ++i) tpdo[i].set_running(operational && tpdo_present[i] && layout_ok[i], now);
  // J§1.5, E§6: LSS only in stopped or pre-operational (digest S.11).
  if (lss) lss->set_ignore(operational);
  refresh_status();
}

canopen::LssAddress SimDevice::Impl::identity_of() const noexcept {
  canopen::LssAddress a;
  a.vendor = spec.vendor.value_or(model.vendor);
  a.product = spec.product.value_or(model.product);
  a.revision = spec.revision.value_or(revision);
  a.serial = spec.serial;
  return a;
}

canopen::LssStoreError SimDevice::Impl::lss_store(const canopen::LssSlave& s) {
  // J§1.5.3, E§6.3: store configuration persists node-ID and bit rate.
  const std::uint8_t node = s.pending_node_id();
  const auto& a = family_facts(family).addressing;
  nv_data.params.set(a.node_id_index, 0, node_value(a, node));
  if (const auto bt = s.pending_bit_timing()) {
    const std::uint16_t kbit = canopen::lss_bit_rate_kbit(*bt);
    if (family == FamilyId::ifm_rm) {
      if (const auto i = ifm_index_for_kbit(kbit)) nv_data.params.set(0x3001, 0, *i);
    } else {
      nv_data.params.set(0x2001, 0, kbit);
    }
  }
  std::string message;
  return persist(message) ? canopen::LssStoreError::kMediaAccess : canopen::LssStoreError::kOk;
}

void SimDevice::Impl::sync_lss_pending() {
  if (!lss) return;
  if (lss->pending_node_id() != pending_node) {
    pending_node = lss->pending_node_id();
    node_to_od(pending_node);
  }
  if (const auto bt = lss->pending_bit_timing()) {
    const std::uint16_t kbit = canopen::lss_bit_rate_kbit(*bt);
    if (kbit != 0 && kbit != pending_kbit) {
      pending_kbit = kbit;
      kbit_to_od(kbit);
    }
  }
}

void SimDevice::Impl::configure_guard() {
  const auto gt = std::chrono::milliseconds(od->get_u16(kGuardTime, 0).value_or(0));
  guard.configure(gt, od->get_u8(kLifeTimeFactor, 0).value_or(0));
}

void SimDevice::Impl::restart_heartbeat(TimePoint now) {
  const std::uint16_t ms = od ? od->get_u16(kHeartbeatTime, 0).value_or(0) : 0;
  next_heartbeat = ms == 0 || !cob::valid_node_id(active_node) ? canopen::kNever : now + std::chrono::milliseconds(ms);
}

void SimDevice::Impl::refresh_status() noexcept {
  if (!od) return;
  family_status();
  if (od->contains(kStatusRegister, 0)) {
    std::uint32_t nmt_bits = 0;  // J§1.9.1, E§10.1 bits 0-1
    switch (nmt.state()) {
      case NmtState::boot_up: nmt_bits = 0; break;
      case NmtState::pre_operational: nmt_bits = 1; break;
      case NmtState::operational: nmt_bits = 2; break;
      case NmtState::stopped: nmt_bits = 3; break;
    }
    (void)od->set_u32(kStatusRegister, 0, ((status | can_status_bits()) & ~0x3U) | nmt_bits);
  }
  if (od->contains(0x6503, 0)) (void)od->set_u16(0x6503, 0, alarms);
  if (od->contains(0x6505, 0)) (void)od->set_u16(0x6505, 0, warnings);
  // CiA 301 0x1001 bit 4 "communication error": a lost life guard, or the
  // controller error passive or bus-off; always with the generic bit 0.
  const bool communication = life_guarding_lost || can_state != CanControllerState::error_active;
  std::uint8_t reg = 0;
  if (faults != 0 || over_range_latched || under_range_latched) reg |= 0x01;
  if ((faults & (fault_bit(FaultKind::voltage_high) | fault_bit(FaultKind::voltage_low))) != 0) reg |= 0x04;
  if ((faults & (fault_bit(FaultKind::temperature_high) | fault_bit(FaultKind::temperature_low))) != 0) reg |= 0x08;
  if (communication) reg |= 0x11;
  emcy.set_error_register(reg);
}

// ---------------------------------------------------------------------------
// TPDOs

void SimDevice::Impl::reconfigure_tpdo(std::size_t i, TimePoint now) {
  const auto comm = static_cast<std::uint16_t>(kTpdoComm + i);
  const auto map = static_cast<std::uint16_t>(kTpdoMap + i);
  layout_ok[i] = false;
  if (!od || !od->contains(comm, 1) || !tpdo_present[i]) return;
  std::array<std::uint32_t, 8> entries{};
  const std::uint8_t n = std::min<std::uint8_t>(od->get_u8(map, 0).value_or(0), 8);
  for (std::uint8_t k = 0; k < n; ++k) entries[k] = od->get_u32(map, static_cast<std::uint8_t>(k + 1)).value_or(0);
  const canopen::ObjectDictionary& dict = *od;
  auto lookup = [&dict](std::uint16_t index, std::uint8_t sub) {
    const auto info = dict.info(index, sub);
    const bool is_signed = info && (info->type == canopen::DataType::kInteger8 ||
                                    info->type == canopen::DataType::kInteger16 ||
                                    info->type == canopen::DataType::kInteger32);
    return is_signed ? canopen::PdoValueKind::signed_integer : canopen::PdoValueKind::unsigned_integer;
  };
  auto result = canopen::build_pdo_layout(std::span<const std::uint32_t>(entries.data(), n), lookup);
  if (result.ok() && n > 0) {
    layout[i] = result.layout;
    layout_ok[i] = true;
  }
  TpdoParams p;
  p.cob_id = od->get_u32(comm, 1).value_or(Tpdo::kInvalid);
  p.type = od->get_u8(comm, 2).value_or(254);
  p.inhibit_100us = static_cast<std::uint32_t>(od->get_raw(comm, 3).value_or(0));
  p.event_ms = od->contains(comm, 5) ? static_cast<std::uint32_t>(od->get_raw(comm, 5).value_or(0)) : 0;
  tpdo[i].configure(p, now);
  tpdo[i].set_running(nmt.state() == NmtState::operational && layout_ok[i], now);
  sampled_valid[i] = false;
}

void SimDevice::Impl::fill_tpdo(std::size_t i, can::Frame& frame) const noexcept {
  const canopen::PdoLayout& l = layout[i];
  std::array<std::int64_t, canopen::PdoLayout::kMaxFields> values{};
  for (std::size_t k = 0; k < l.field_count(); ++k) {
    const canopen::PdoField& f = l.field(k);
    values[k] = f.dummy ? 0 : static_cast<std::int64_t>(od->get_raw(f.index, f.sub).value_or(0));
  }
  (void)l.encode(std::span<const std::int64_t>(values.data(), l.field_count()), frame);
}

void SimDevice::Impl::send_tpdo(std::size_t i, TimePoint now) {
  can::Frame frame;
  frame.id = tpdo[i].can_id();
  if (tpdo[i].uses_sampled_data() && sampled_valid[i]) {
    frame = sampled[i];
    frame.id = tpdo[i].can_id();
  } else {
    fill_tpdo(i, frame);
  }
  (void)send(frame, TruthRecord::Kind::tpdo, static_cast<std::uint8_t>(i + 1));
  tpdo[i].sent(now);
}

// ---------------------------------------------------------------------------
// Frames and time

void SimDevice::Impl::on_frame(const can::Frame& frame, TimePoint now) {
  if (!powered || silent) return;
  if (frame.is_error()) {
    on_error_frame(frame, now);
    return;
  }
  if (frame.is_extended() || can_state == CanControllerState::bus_off) return;
  now_cache = now;
  const bool configured = cob::valid_node_id(active_node);

  if (frame.id == canopen::cob::kNmt) {
    if (!configured) return;
    const canopen::NmtTransition t = nmt.on_frame(frame, active_node);
    switch (t.outcome) {
      case canopen::NmtOutcome::reset_node: reset_node(now); break;
      case canopen::NmtOutcome::reset_communication: reset_communication(now); break;
      case canopen::NmtOutcome::state_changed: on_nmt_change(t.from, now); break;
      default: break;
    }
    return;
  }
  if (frame.id == canopen::cob::kLssMasterToSlave) {
    if (!lss) return;
    (void)lss->on_frame(frame);
    sync_lss_pending();
    if (lss->take_bit_timing_activation()) active_kbit = pending_kbit;
    if (lss->take_reset_communication_request()) reset_communication(now);
    return;
  }
  if (!configured) return;
  if (reboot_on_sdo != 0 && frame.id == cob::kSdoRxBase + active_node && --reboot_on_sdo == 0) {
    power_off();
    if (power_on(now)) powered = false;  // the nv file went bad: stays off, as a real device would
    return;
  }

  const std::uint32_t sync_cob = od->get_u32(kCobIdSync, 0).value_or(canopen::cob::kSync) & 0x7FFu;
  if (frame.id == sync_cob && !frame.is_rtr()) {
    if (!canopen::parse_sync(frame, sync_cob).ok() || !nmt.allows(canopen::NmtService::sync)) return;
    for (std::size_t i = 0; i < 2; ++i) {
      if (!tpdo_present[i]) continue;
      tpdo[i].on_sync(now);
      if (tpdo[i].sample_pending()) {
        fill_tpdo(i, sampled[i]);
        sampled_valid[i] = true;
      }
      if (nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
    }
    return;
  }
  if (frame.is_rtr()) {
    if (frame.id == canopen::cob::kNmtErrorControlBase + active_node) {
      if (!nmt.allows(canopen::NmtService::error_control)) return;
      can::Frame reply;
      if (guard.on_frame(frame, active_node, nmt.state(), now, reply)) {
        if (life_guarding_lost) family_life_guarding(false);
        (void)send(reply, TruthRecord::Kind::guard);
      }
      return;
    }
    for (std::size_t i = 0; i < 2; ++i) {
      if (!tpdo_present[i] || frame.id != tpdo[i].can_id()) continue;
      if (tpdo[i].on_rtr(now) && nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
    }
    return;
  }
  if (sdo && nmt.allows(canopen::NmtService::sdo)) {
    (void)sdo->on_frame(frame, now);
    if (reset_node_requested) {
      // ifm 0x2300: the confirmation went out above, now the reset (F§6.3.4).
      reset_node_requested = false;
      reset_node(now);
    }
  }
}

TimePoint SimDevice::Impl::process(TimePoint now) {
  if (!powered || silent) return canopen::kNever;
  now_cache = now;
  if (now >= next_measure) {
    measure(now);
    const auto behind = (now - next_measure) / kMeasuringCycle;
    next_measure += kMeasuringCycle * (behind + 1);
  }
  if (now >= next_heartbeat && nmt.allows(canopen::NmtService::error_control)) {
    (void)send(canopen::make_heartbeat(active_node, nmt.state()), TruthRecord::Kind::heartbeat);
    const auto period = std::chrono::milliseconds(od->get_u16(kHeartbeatTime, 0).value_or(0));
    if (period.count() == 0) {
      next_heartbeat = canopen::kNever;
    } else {
      const auto behind = (now - next_heartbeat) / period;
      next_heartbeat += period * (behind + 1);
    }
  }
  TimePoint next = std::min(next_measure, next_heartbeat);
  next = std::min(next, guard.process(now));
  next = std::min(next, emcy.process(now));
  for (std::size_t i = 0; i < 2; ++i) {
    if (!tpdo_present[i]) continue;
    if (nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
    next = std::min(next, tpdo[i].next_deadline());
  }
  if (sdo) next = std::min(next, sdo->process(now));
  next = std::min(next, late_lss.release(now, [this](const can::Frame& f) { (void)send(f, TruthRecord::Kind::lss); }));
  return next;
}

void SimDevice::Impl::measure(TimePoint now) {
  bool changed = false;
  for (std::size_t ch = 0; ch < channels; ++ch) {
    ChannelSample s = encoder.measure(static_cast<int>(ch), now);
    const ChannelSample before = last[ch];
    family_publish(ch, s, before, first_measure);
    changed = changed || first_measure || s.position != before.position || s.speed != before.speed ||
              s.cams != before.cams || s.work_area != before.work_area;
    last[ch] = s;
  }
  first_measure = false;
  if (family == FamilyId::novotechnik_multiturn) condition_cycle(last[0], now);
  for (std::size_t i = 0; i < 2; ++i)
    if (tpdo_present[i]) tpdo[i].on_measure(now, changed);
}

void SimDevice::Impl::inject(FaultKind fault, TimePoint now) {
  if (!powered) return;
  now_cache = now;
  family_fault(fault, now);
  refresh_status();
}

// ---------------------------------------------------------------------------
// Family dispatch

void SimDevice::Impl::family_factory() {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_factory(); break;
    case FamilyId::novotechnik_multiturn: multiturn_factory(); break;
    case FamilyId::ifm_rm: ifm_factory(); break;
  }
}

void SimDevice::Impl::family_adjust(canopen::EntryDef& def) const {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_adjust(def); break;
    case FamilyId::novotechnik_multiturn: break;
    case FamilyId::ifm_rm: ifm_adjust(def); break;
  }
}

void SimDevice::Impl::family_extras() {
  if (family == FamilyId::novotechnik_multiturn) multiturn_extras();
}

std::uint32_t SimDevice::Impl::family_on_write(const canopen::WriteRequest& req) {
  switch (family) {
    case FamilyId::novotechnik_rotary: return rotary_on_write(req);
    case FamilyId::novotechnik_multiturn: return multiturn_on_write(req);
    case FamilyId::ifm_rm: return ifm_on_write(req);
  }
  return 0;
}

void SimDevice::Impl::family_after_write(std::uint16_t index, std::uint8_t sub) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_after_write(index, sub); break;
    case FamilyId::novotechnik_multiturn: multiturn_after_write(index, sub); break;
    case FamilyId::ifm_rm: ifm_after_write(index, sub); break;
  }
}

void SimDevice::Impl::family_publish(std::size_t ch, ChannelSample& s, const ChannelSample& before, bool first) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_publish(ch, s, before, first); break;
    case FamilyId::novotechnik_multiturn: multiturn_publish(s, before, first); break;
    case FamilyId::ifm_rm: ifm_publish(s, before, first); break;
  }
}

void SimDevice::Impl::family_fault(FaultKind fault, TimePoint now) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_fault(fault, now); break;
    case FamilyId::novotechnik_multiturn: multiturn_fault(fault, now); break;
    case FamilyId::ifm_rm: ifm_fault(fault, now); break;
  }
}

void SimDevice::Impl::family_life_guarding(bool lost) {
  if (lost == life_guarding_lost) return;
  life_guarding_lost = lost;
  switch (family) {
    case FamilyId::novotechnik_rotary: break;  // J documents no reaction and no EMCY
    case FamilyId::novotechnik_multiturn: multiturn_life_guarding(lost); break;
    case FamilyId::ifm_rm: ifm_life_guarding(lost); break;
  }
  refresh_status();
}

void SimDevice::Impl::family_status() noexcept {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_status(); break;
    case FamilyId::novotechnik_multiturn: multiturn_status(); break;
    case FamilyId::ifm_rm: break;  // F: no 0x1002, 0x6503, 0x6505
  }
}

// ---------------------------------------------------------------------------
// SimDevice

SimDevice::SimDevice(DeviceSpec spec, const device::DeviceDescription& description, can::FrameSink& sink,
                     std::filesystem::path state_dir)
    : impl_(std::make_unique<Impl>(std::move(spec), description, sink, std::move(state_dir))) {
  assert(impl_->spec.model != nullptr);
}

SimDevice::~SimDevice() = default;

std::error_code SimDevice::power_on(TimePoint now) { return impl_->power_on(now); }
void SimDevice::power_off() { impl_->power_off(); }
void SimDevice::set_silent(bool silent) { impl_->silent = silent; }
void SimDevice::reboot_on_sdo(std::uint32_t nth) noexcept { impl_->reboot_on_sdo = nth; }
bool SimDevice::powered() const noexcept { return impl_->powered; }
void SimDevice::on_frame(const can::Frame& frame, TimePoint now) { impl_->on_frame(frame, now); }
TimePoint SimDevice::process(TimePoint now) { return impl_->process(now); }
void SimDevice::inject(FaultKind fault, TimePoint now) { impl_->inject(fault, now); }
void SimDevice::set_truth_sink(TruthSink sink) { impl_->truth = std::move(sink); }
const DeviceSpec& SimDevice::spec() const noexcept { return impl_->spec; }
std::uint8_t SimDevice::node_id() const noexcept { return impl_->active_node; }
std::uint64_t SimDevice::late_lss_answers() const noexcept { return impl_->late_lss.released(); }
canopen::NmtState SimDevice::nmt_state() const noexcept { return impl_->nmt.state(); }
canopen::LssAddress SimDevice::identity() const noexcept { return impl_->identity_of(); }
std::uint16_t SimDevice::bitrate_kbit() const noexcept { return impl_->active_kbit; }
const canopen::ObjectDictionary* SimDevice::object_dictionary() const noexcept { return impl_->od.get(); }
const std::filesystem::path& SimDevice::nv_path() const noexcept { return impl_->nv_file; }
void SimDevice::move_by(double turns) noexcept { impl_->encoder.move_by(turns); }
std::error_code SimDevice::set_motion(std::string_view motion, TimePoint now) {
  if (const std::error_code ec = impl_->encoder.set_motion(motion, now)) return ec;
  impl_->spec.motion = std::string(motion);
  return {};
}

}  // namespace cobridge::sim
