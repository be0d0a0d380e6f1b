// Identity probe: see identity_probe.hpp.
#include "bus/discovery/identity_probe.hpp"

#include "canopen/cob_id.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus::discovery {

using canopen::kNever;
using canopen::TimePoint;

namespace {

constexpr std::uint16_t kIdentityObject = 0x1018;  // CiA 301 identity object

can::Frame upload_request(std::uint8_t node, std::uint8_t sub) {
  return can::Frame::make8(canopen::cob::kSdoRxBase + node,
                           {0x40, static_cast<std::uint8_t>(kIdentityObject & 0xFF),
                            static_cast<std::uint8_t>(kIdentityObject >> 8), sub, 0, 0, 0, 0});
}

}  // namespace

bool IdentityProbe::on_sdo_answer(const can::Frame& f, TimePoint now) noexcept {
  const auto n = static_cast<std::uint8_t>(f.id - canopen::cob::kSdoTxBase);
  const auto index = static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8));
  const std::uint8_t sub = f.data[3];
  const std::uint8_t cs = f.data[0];
  if (!round_.active || !round_.in[n] || index != kIdentityObject || sub != round_.sub) return false;
  NodeState& st = state_[n];
  if (cs == 0x80) {
    st.aborted = true;
  } else if ((cs & 0xE0) == 0x40 && (cs & 0x02) != 0) {  // expedited upload response
    std::uint32_t v = static_cast<std::uint32_t>(f.data[4]) | (static_cast<std::uint32_t>(f.data[5]) << 8) |
                      (static_cast<std::uint32_t>(f.data[6]) << 16) | (static_cast<std::uint32_t>(f.data[7]) << 24);
    if ((cs & 0x01) != 0) {
      const unsigned bytes = 4u - ((cs >> 2) & 0x03u);
      if (bytes < 4) v &= (1u << (8 * bytes)) - 1u;
    }
    st.vals[static_cast<std::size_t>(sub - 1)].add(v);
  }
  round_.answered.set(n);
  round_.last_answer = now;
  return true;
}

void IdentityProbe::on_error_control(const can::Frame& f, TimePoint now, bool may_clash) noexcept {
  const auto n = static_cast<std::uint8_t>(f.id - canopen::cob::kNmtErrorControlBase);
  if (f.data[0] != 0) return;  // heartbeat / guarding: the bus manager's
  NodeState& st = state_[n];
  // A boot-up in place of the answer to this round's request is the asked
  // device rebooting (it lost the request): a second device at the node
  // would not have kept the first from answering.
  const bool instead_of_answer = round_.active && round_.in[n] && !round_.answered[n];
  if (st.last_bootup != TimePoint::min() && now - st.last_bootup < opt_.bootup_clash_window && may_clash &&
      !instead_of_answer)
    st.bootup_clash = true;
  st.last_bootup = now;
  bootups_.set(n);
}

std::bitset<128> IdentityProbe::take_bootups() noexcept { return std::exchange(bootups_, {}); }

void IdentityProbe::want(std::uint8_t n, bool bootup) noexcept {
  if (!enabled_) return;
  want_.set(n);
  if (bootup) want_bootup_.set(n);
}

void IdentityProbe::request(std::uint8_t n) noexcept {
  if (!canopen::cob::valid_node_id(n) || !enabled_) return;
  if (round_.active && std::find(round_.members.begin(), round_.members.end(), n) != round_.members.end()) return;
  want_.set(n);
}

std::optional<std::uint8_t> IdentityProbe::present_at(const LssAddress& a) const {
  for (std::uint8_t n = 1; n <= 127; ++n)
    for (const auto& id : picture_[n].ids)
      if (same_device(id, a)) return n;
  return std::nullopt;
}

void IdentityProbe::begin(TimePoint now, bool full, const std::bitset<128>& also, canopen::Duration window) {
  want_ |= also;
  round_ = Round{};
  round_.active = true;
  round_.full = full;
  round_.window = window;
  round_.sub = 1;
  round_.started = now;
  for (std::uint8_t n = 1; n <= 127; ++n) {
    if (!want_[n]) continue;
    round_.members.push_back(n);
    round_.in.set(n);
    if (want_bootup_[n]) round_.bootup.set(n);
    state_[n].vals = {};
    state_[n].aborted = false;
  }
  want_.reset();
  want_bootup_.reset();
  begin_sub(now);
}

void IdentityProbe::begin_sub(TimePoint now) {
  round_.answered.reset();
  round_.to_send = round_.members.size();
  round_.deadline = kNever;
  round_.last_answer = now;
  send_frames(now);
}

void IdentityProbe::send_frames(TimePoint now) {
  std::uint32_t n = 0;
  while (round_.to_send > 0 && n < opt_.burst) {
    const std::uint8_t node = round_.members[round_.members.size() - round_.to_send];
    if (!sink_.send(upload_request(node, round_.sub))) break;
    --round_.to_send;
    ++n;
  }
  if (round_.to_send == 0 && round_.deadline == kNever)
    round_.deadline = now + (round_.window > canopen::Duration::zero() ? std::min(round_.window, sdo_timeout_)
                                                                       : sdo_timeout_);
}

bool IdentityProbe::all_answered() const noexcept {
  return std::all_of(round_.members.begin(), round_.members.end(), [&](std::uint8_t n) { return round_.answered[n]; });
}

bool IdentityProbe::drive(TimePoint now, ProbeListener& l) {
  if (!round_.active) return false;
  if (round_.to_send > 0) {
    send_frames(now);
    return false;
  }
  const bool settled = all_answered() && now >= round_.last_answer + opt_.probe_settle;
  if (!settled && now < round_.deadline) return false;
  // Only nodes that answered the previous sub-index go on to the next.
  if (round_.sub < 4) {
    std::vector<std::uint8_t> next;
    for (std::uint8_t n : round_.members)
      if (round_.answered[n] && !state_[n].aborted) next.push_back(n);
    for (std::uint8_t n : round_.members)
      if (!round_.answered[n] || state_[n].aborted) l.on_probed(finish_node(n));
    if (!next.empty()) {
      round_.members = std::move(next);
      ++round_.sub;
      begin_sub(now);
      return true;
    }
  } else {
    for (std::uint8_t n : round_.members) l.on_probed(finish_node(n));
  }
  l.on_round_end(round_.full, now - round_.started);
  round_ = Round{};
  return true;
}

TimePoint IdentityProbe::next_deadline(TimePoint now) const noexcept {
  TimePoint next = kNever;
  if (!round_.active) return next;
  if (round_.to_send > 0) next = std::min(next, now + std::chrono::milliseconds(1));
  next = std::min(next, round_.deadline);
  if (all_answered()) next = std::min(next, round_.last_answer + opt_.probe_settle);
  return next;
}

ProbeResult IdentityProbe::finish_node(std::uint8_t n) {
  NodePicture& pic = picture_[n];
  NodeState& st = state_[n];
  const IdentityAnswers& vals = st.vals;
  ProbeResult r;
  r.node = n;
  r.bootup = round_.bootup[n];
  r.full = round_.full;
  if (vals[0].n == 0 && !st.aborted) {
    r.kind = ProbeResult::Kind::nobody;
    r.changed = !pic.ids.empty() || pic.clash || pic.unsure;
    r.was_known = !pic.ids.empty() || pic.clash;
    pic.unsure = false;
    if (r.was_known) {
      pic.ids.clear();
      pic.clash = false;
      st.clash_reported = false;
    }
    return r;
  }
  if (st.aborted) {
    // Someone is there, so it is no longer unsure; who, the probe cannot tell.
    r.kind = ProbeResult::Kind::refused;
    r.changed = pic.unsure;
    pic.unsure = false;
    return r;
  }
  if (vals[1].n == 0 || vals[2].n == 0 || vals[3].n == 0) {
    r.kind = ProbeResult::Kind::incomplete;
    want(n, r.bootup);
    return r;
  }
  const bool clash = vals[0].n > 1 || vals[1].n > 1 || vals[2].n > 1 || vals[3].n > 1 || st.bootup_clash;
  pic.seen = vals;
  if (clash) take_clash(n, r);
  else take_identity(n, LssAddress{vals[0].v[0], vals[1].v[0], vals[2].v[0], vals[3].v[0]}, r);
  return r;
}

void IdentityProbe::take_identity(std::uint8_t n, const LssAddress& a, ProbeResult& r) {
  NodePicture& pic = picture_[n];
  r.kind = ProbeResult::Kind::identified;
  r.changed = pic.unsure || pic.clash || pic.ids.size() != 1 || !same_device(pic.ids[0], a);
  pic.unsure = false;
  pic.ids = {a};
  pic.last = {a};
  pic.clash = false;
  state_[n].clash_reported = false;
}

void IdentityProbe::take_clash(std::uint8_t n, ProbeResult& r) {
  NodePicture& pic = picture_[n];
  NodeState& st = state_[n];
  const IdentityAnswers& vals = st.vals;
  r.kind = ProbeResult::Kind::clash;
  r.changed = true;
  for (const auto& v : vals) r.count = std::max<std::uint32_t>(r.count, v.n);
  // Two boot-ups within the window, one identity answered: the answers of
  // two devices can collide on the wire; take it as a clash anyway.
  if (st.bootup_clash && r.count < 2) r.count = 2;
  st.bootup_clash = false;
  pic.ids.clear();
  pic.unsure = false;
  if (vals[0].n == 1 && vals[1].n == 1 && vals[2].n == 1)
    for (std::uint8_t i = 0; i < vals[3].n; ++i)
      pic.ids.push_back(LssAddress{vals[0].v[0], vals[1].v[0], vals[2].v[0], vals[3].v[i]});
  pic.clash = true;
  r.first_report = !st.clash_reported;
  st.clash_reported = true;
}

}  // namespace cobridge::bus::discovery
