// The two TPDOs as the object dictionary configures them: layout from the
// mapping record, timing from the communication record, frames filled from
// the mapped objects.
#include "device/sim_device_impl.hpp"

#include <algorithm>
#include <bit>
#include <chrono>

#include "canopen/cob_id.hpp"
#include "canopen/sync.hpp"
#include "device/od_builder.hpp"
#include "device/storage.hpp"
#include "families/ifm_rm.hpp"

namespace cobridge::sim {

using namespace device_objects;

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

}  // namespace cobridge::sim
