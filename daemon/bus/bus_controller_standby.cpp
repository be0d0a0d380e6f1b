// The bus manager as standby of a hot-standby pair: what it learns by
// listening, so that its outputs are live and a takeover finds what the
// master knew.
//
// It sends nothing (bus_controller_election.cpp gates every send). From the
// bus it learns:
//   - the node-ID of each configured device the master identified: the
//     master's expedited SDO uploads of the identity object 0x1018 (CiA 301
//     7.5.2.36; sub 1 vendor, 2 product, 3 revision, 4 serial) name the node
//     in their COB-ID, so a device the master commissioned with LSS is
//     known here by its serial without any request of its own. Only the
//     response to an upload request seen on the bus, within the SDO timeout,
//     counts: a response nobody asked for (any node can send one) is not
//     written into this gateway's state file;
//   - which devices are in operation (their heartbeat, CiA 301 7.2.8.3.2):
//     its status shows such a device operational (configured by the master)
//     rather than the state its own control thread left it in.
// A device heard in operation is announced to the outputs with the mapping
// its plan sets, and remembered in this gateway's state store with the
// plan's fingerprint, as the master remembered it: a takeover starts from
// that table as a second start does, with no commissioning and no writes.
// Control thread only.
#include "bus/bus_controller.hpp"
#include "bus/description_choice.hpp"

namespace cobridge::bus {
namespace {

constexpr std::uint32_t kSdoResponseBase = 0x580;
constexpr std::uint16_t kIdentityObject = 0x1018;

// An expedited upload response (CiA 301 7.2.4.3.3: scs 2, e = 1) carries
// the value in bytes 4..7.
bool expedited_upload_response(const can::Frame& f) noexcept {
  return f.len == 8 && (f.data[0] & 0xE2) == 0x42;
}

std::uint32_t le32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

}  // namespace

void BusController::listen_as_standby(const can::Frame& frame, TimePoint now) {
  if (frame.is_extended() || frame.is_rtr()) return;
  if (frame.id > canopen::cob::kNmtErrorControlBase && frame.id <= canopen::cob::kNmtErrorControlBase + 127) {
    note_heartbeat(frame);
  } else if (frame.id > kSdoResponseBase && frame.id <= kSdoResponseBase + 127) {
    note_identity(frame, now);
  } else if (frame.id > canopen::cob::kSdoRxBase && frame.id <= canopen::cob::kSdoRxBase + 127) {
    note_identity_request(frame, now);
  }
}

void BusController::note_heartbeat(const can::Frame& frame) {
  if (frame.len != 1) return;
  const auto node = static_cast<std::uint8_t>(frame.id - canopen::cob::kNmtErrorControlBase);
  if (DeviceAgent* m = find_configured_node(node)) {
    const bool operational =
        (frame.data[0] & 0x7F) == static_cast<std::uint8_t>(canopen::NmtState::operational);
    if (m->note_heard_state(operational)) dirty = true;  // the status shows it
  }
}

// An upload initiate request (CiA 301 7.2.4.3.2: ccs 2, byte 0 = 0x40) of
// 0x1018 sub 1..4.
void BusController::note_identity_request(const can::Frame& frame, TimePoint now) {
  if (frame.len != 8 || frame.data[0] != 0x40) return;
  const auto index = static_cast<std::uint16_t>(frame.data[1] | frame.data[2] << 8);
  const std::uint8_t sub = frame.data[3];
  const auto node = static_cast<std::uint8_t>(frame.id - canopen::cob::kSdoRxBase);
  asked_identity[node] = index == kIdentityObject && sub >= 1 && sub <= 4 ? AskedIdentity{sub, now} : AskedIdentity{};
}

void BusController::note_identity(const can::Frame& frame, TimePoint now) {
  if (!expedited_upload_response(frame)) return;
  const auto index = static_cast<std::uint16_t>(frame.data[1] | frame.data[2] << 8);
  const std::uint8_t sub = frame.data[3];
  if (index != kIdentityObject || sub < 1 || sub > 4) return;
  const auto node = static_cast<std::uint8_t>(frame.id - kSdoResponseBase);
  const AskedIdentity asked = std::exchange(asked_identity[node], AskedIdentity{});
  if (asked.sub != sub || now - asked.at > milliseconds(bus.sdo_timeout_ms)) return;  // nobody asked
  canopen::LssAddress& id = heard_identity[node];
  const std::uint32_t v = le32(&frame.data[4]);
  (sub == 1 ? id.vendor : sub == 2 ? id.product : sub == 3 ? id.revision : id.serial) = v;
  if (sub != 4) return;
  for (auto& m : devices) {
    if (!m.note_identity_heard(id, node)) continue;
    dirty = true;
    log->info("bus {}: standby: device {} is at node {} (the master read its identity)", bus.name, m.st.name, node);
  }
}

// The standby's outputs are live before any takeover: each configured
// device heard in operation is announced with the TPDO mapping its plan
// sets, which the master has configured and verified.
void BusController::follow_heard_devices() {
  for (auto& m : devices) {
    if (!m.to_follow()) continue;
    if (m.description == nullptr) {
      auto chosen = description_from_config(catalog, m.cfg, m.st.identity);
      if (!chosen.ok()) continue;
      m.description = chosen->description;
      m.profile = chosen->profile;
    }
    const auto plan = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
    if (!plan.ok()) continue;
    m.followed = true;
    remember_followed(m, plan.plan->fingerprint);
    if (options.observer == nullptr) continue;
    std::vector<std::uint32_t> tpdo1, tpdo2;
    for (const auto& step : plan.plan->steps) {
      if (step.kind != StepKind::tpdo_mapping) continue;
      (step.tpdo == 1 ? tpdo1 : tpdo2) = step.mapping;
    }
    options.observer->on_device_configured(m.st, tpdo1, tpdo2);
    log->info("bus {}: standby: decoding device {} at node {} as the configuration maps it", bus.name, m.st.name,
              m.st.node_id);
  }
}

// The device runs with the plan's settings (the master started it after
// applying them): the same record the master keeps.
void BusController::remember_followed(const DeviceAgent& m, const std::string& fingerprint) {
  if (m.st.identity.serial != 0) remember_assignment(m, fingerprint);
}

}  // namespace cobridge::bus
