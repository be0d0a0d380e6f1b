// SimDevice: one simulated encoder, the facade over SimDevice::Impl, and
// the transmit path every frame the device sends takes (the truth records
// of the end-to-end tests are written there). The concepts of the runtime
// live in the files sim_device_impl.hpp lists.
#include "device/sim_device.hpp"

#include <fmt/format.h>

#include <cassert>

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

SimDevice::Impl::Impl(DeviceSpec spec_in, const device::DeviceDescription& description, can::FrameSink& sink,
                      std::filesystem::path state_dir)
    : spec(std::move(spec_in)),
      model(*spec.model),
      family(spec.model->family),
      traits(families::traits(spec.model->family)),
      desc(description),
      bus(sink),
      nv_file(state_dir.empty() ? std::filesystem::path{}
                                : state_dir / fmt::format("{}-{}.nv", family_name(family), spec.serial)),
      nv(nv_file) {
  tx.device = this;
  late_lss = LateAnswers(spec.late_lss, std::chrono::milliseconds(spec.late_lss_ms));
  factory_node = spec.node_id == 0 ? model.factory_node_id : spec.node_id;
  factory_kbit = spec.bitrate_kbit != 0 ? spec.bitrate_kbit : model.factory_bitrate_kbit;
  if (const device::ObjectDesc* ch = desc.find(0x6020, 0); ch != nullptr && traits.channel_count_in_eds)
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

void SimDevice::Impl::send_emcy(const canopen::Emcy& e, families::EmcyLevel level) noexcept {
  if (!nmt.allows(canopen::NmtService::emcy)) return;
  (void)emcy.send(e, level, now_cache);
}

SimDevice::SimDevice(DeviceSpec spec, const device::DeviceDescription& description, can::FrameSink& sink,
                     std::filesystem::path state_dir)
    : impl_(std::make_unique<Impl>(std::move(spec), description, sink, std::move(state_dir))) {
  assert(impl_->spec.model != nullptr);
}

SimDevice::~SimDevice() = default;

Error SimDevice::power_on(TimePoint now) { return impl_->power_on(now); }
void SimDevice::power_off() { impl_->power_off(); }
void SimDevice::set_silent(bool silent) { impl_->silent = silent; }
void SimDevice::reboot_on_sdo(std::uint32_t nth) noexcept { impl_->reboot_on_sdo = nth; }
void SimDevice::abort_sdo(std::uint16_t index, std::uint32_t code) noexcept {
  impl_->abort_sdo_index = index;
  impl_->abort_sdo_code = code;
}
void SimDevice::ignore_sdo(std::uint16_t index, std::uint32_t n) noexcept {
  impl_->ignore_sdo_index = n == 0 ? 0 : index;
  impl_->ignore_sdo_left = n;
}
void SimDevice::ignore_nmt_start(std::uint32_t n) noexcept { impl_->ignore_nmt_starts = n; }
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
Error SimDevice::set_motion(std::string_view motion, TimePoint now) {
  if (Error e = impl_->encoder.set_motion(motion, now)) return e;
  impl_->spec.motion = std::string(motion);
  return {};
}

}  // namespace cobridge::sim
