#include "pipeline/frame_decoder.hpp"

#include "canopen/cob_id.hpp"

#include <cstring>

namespace cobridge::pipeline {
namespace {

// Little-endian bit field of up to 32 bits at any bit offset within 8 bytes.
inline std::uint64_t bits_at(const std::array<std::uint8_t, 8>& d, unsigned offset, unsigned length) noexcept {
  std::uint64_t word = 0;
  for (unsigned i = 0; i < 8; ++i) word |= static_cast<std::uint64_t>(d[i]) << (8 * i);
  const std::uint64_t mask = length >= 64 ? ~0ull : ((1ull << length) - 1);
  return (word >> offset) & mask;
}

inline std::int64_t sign_extend(std::uint64_t v, unsigned length) noexcept {
  const std::uint64_t sign = 1ull << (length - 1);
  return static_cast<std::int64_t>((v ^ sign) - sign);
}

// Stores one mapped field's value in the sample, marking it valid.
inline void store_signal(const FieldDecode& fd, std::int64_t v, const DecodePlan& plan, Sample& out) noexcept {
  switch (fd.signal) {
    case Signal::position: {
      const std::int64_t pos = fd.is_signed ? v : static_cast<std::int64_t>(static_cast<std::uint64_t>(v) & plan.position_mask);
      out.position = pos;
      out.position_eng = static_cast<double>(pos) * plan.eng_scale + plan.eng_offset;
      out.valid |= COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG;
      break;
    }
    case Signal::speed:
      out.speed = static_cast<std::int32_t>(v);
      out.valid |= COBRIDGE_VALID_SPEED;
      break;
    case Signal::cam:
      out.cam_state = static_cast<std::uint8_t>(v);
      out.valid |= COBRIDGE_VALID_CAM_STATE;
      break;
    case Signal::work_area:
      out.work_area_state = static_cast<std::uint8_t>(v);
      out.valid |= COBRIDGE_VALID_WORK_AREA_STATE;
      break;
    case Signal::alarms:
      out.alarms = static_cast<std::uint16_t>(v);
      out.valid |= COBRIDGE_VALID_ALARMS;
      break;
    case Signal::warnings:
      out.warnings = static_cast<std::uint16_t>(v);
      out.valid |= COBRIDGE_VALID_WARNINGS;
      break;
    case Signal::temperature:
      out.temperature_dC = static_cast<std::int16_t>(v);
      out.valid |= COBRIDGE_VALID_TEMPERATURE;
      break;
    case Signal::voltage:
      out.voltage_dV = static_cast<std::uint16_t>(v);
      out.valid |= COBRIDGE_VALID_VOLTAGE;
      break;
    case Signal::none:
      break;
  }
}

}  // namespace

FrameDecoder::FrameDecoder(std::uint8_t bus_index, const DeviceTable& table) : bus_index_(bus_index), table_(table) {
  refresh();
}

void FrameDecoder::refresh() {
  // One atomic load while nothing changed: the constructor's snapshot holds
  // the table as it was at generation 0 too, so an empty table costs no lock.
  if (table_.generation() == generation_ && synced_) return;
  table_.snapshot(plans_, generation_);
  synced_ = true;
}

void FrameDecoder::header(const can::Frame& f, std::uint8_t node, std::uint8_t kind, Sample& out) noexcept {
  std::memset(&out, 0, sizeof out);
  out.rx_timestamp_ns = static_cast<std::uint64_t>(f.timestamp_ns);
  if (f.timestamp_ns != 0) out.rx_monotonic_ns = static_cast<std::uint64_t>(f.timestamp_ns + mono_minus_real_);
  out.sequence = ++sequence_[node];
  out.device_index = plans_[node].device_index;
  out.bus_index = bus_index_;
  out.node_id = node;
  out.kind = kind;
  out.cob_id = static_cast<std::uint16_t>(f.id);
  out.raw_len = f.len > 8 ? 8 : f.len;
  std::memcpy(out.raw, f.data.data(), out.raw_len);
  out.kind_sequence = ++kind_sequence_[node][kind < kKinds ? kind : 0];
  out.valid = COBRIDGE_VALID_RAW | COBRIDGE_VALID_KIND_SEQUENCE |
              (f.timestamp_ns != 0 ? COBRIDGE_VALID_RX_MONOTONIC : 0);
}

bool FrameDecoder::gateway_header(std::uint8_t node, std::uint8_t kind, std::int64_t timestamp_ns,
                                  Sample& out) noexcept {
  if (node == 0 || node >= DeviceTable::kNodes || !indexed(node)) return false;
  can::Frame none;  // no frame caused it: no COB-ID, no payload
  none.timestamp_ns = timestamp_ns;
  header(none, node, kind, out);
  out.cob_id = 0;
  out.raw_len = 0;
  return true;
}

bool FrameDecoder::decode(const can::Frame& f, Sample& out) noexcept {
  count(frames_);
  if (f.is_extended() || f.is_error()) {
    count(ignored_);
    return false;
  }
  const std::uint32_t id = f.id;
  namespace cob = canopen::cob;
  if (id == cob::kSync) {
    sync_counter_ = f.len >= 1 ? f.data[0] : 0;
    return false;
  }
  if (f.is_rtr()) {
    count(ignored_);
    return false;
  }
  bool ok = false;
  if (id > cob::kTpdo1Base && id <= cob::kTpdo1Base + 127) {
    ok = decode_tpdo(f, static_cast<std::uint8_t>(id - cob::kTpdo1Base), 0, out);
  } else if (id > cob::kTpdo2Base && id <= cob::kTpdo2Base + 127) {
    ok = decode_tpdo(f, static_cast<std::uint8_t>(id - cob::kTpdo2Base), 1, out);
  } else if (id > cob::kEmcyBase && id <= cob::kEmcyBase + 127) {
    const auto node = static_cast<std::uint8_t>(id - cob::kEmcyBase);
    if (f.len != 8) {  // CiA 301 §7.2.7.3.1: EMCY is 8 bytes
      count(bad_length_);
      return false;
    }
    if (!indexed(node)) return false;
    header(f, node, COBRIDGE_SAMPLE_EMCY, out);
    out.emcy_code = static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8));
    out.emcy_register = f.data[2];
    std::memcpy(out.emcy_data, &f.data[3], 5);
    out.valid |= COBRIDGE_VALID_EMCY;
    ok = true;
  } else if (id > cob::kNmtErrorControlBase && id <= cob::kNmtErrorControlBase + 127) {
    const auto node = static_cast<std::uint8_t>(id - cob::kNmtErrorControlBase);
    if (f.len != 1) {
      count(bad_length_);
      return false;
    }
    if (!indexed(node)) return false;
    header(f, node, COBRIDGE_SAMPLE_HEARTBEAT, out);
    out.nmt_state = static_cast<std::uint8_t>(f.data[0] & 0x7F);
    out.online = 1;
    out.valid |= COBRIDGE_VALID_NMT_STATE;
    ok = true;
  } else {
    count(ignored_);
    return false;
  }
  if (ok) count(samples_);
  return ok;
}

bool FrameDecoder::decode_tpdo(const can::Frame& f, std::uint8_t node, std::size_t pdo, Sample& out) noexcept {
  const DecodePlan& plan = plans_[node];
  if (!plan.active || !plan.indexed || plan.tpdo[pdo].count == 0) {
    count(unknown_node_);
    return false;
  }
  const PdoDecode& d = plan.tpdo[pdo];
  if (f.len < d.frame_length) {  // CiA 301: a too-short PDO is not processed (EMCY 0x8210 case)
    count(bad_length_);
    return false;
  }
  header(f, node, COBRIDGE_SAMPLE_TPDO, out);
  if (plan.synchronous[pdo]) out.sync_counter = sync_counter_;
  for (std::size_t i = 0; i < d.count; ++i) {
    const FieldDecode& fd = d.fields[i];
    const std::uint64_t raw = bits_at(f.data, fd.bit_offset, fd.bit_length);
    const std::int64_t v = fd.is_signed ? sign_extend(raw, fd.bit_length) : static_cast<std::int64_t>(raw);
    store_signal(fd, v, plan, out);
  }
  last_pdo_ns_[node] = f.timestamp_ns + mono_minus_real_;
  if (stale_[node]) stale_[node] = false;
  return true;
}

bool FrameDecoder::make_status(std::uint8_t node_id, bool online, bool stale, std::uint8_t nmt_state,
                               std::int64_t timestamp_ns, Sample& out) noexcept {
  if (!gateway_header(node_id, COBRIDGE_SAMPLE_STATUS, timestamp_ns, out)) return false;
  out.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_NMT_STATE |
              (out.valid & (COBRIDGE_VALID_RX_MONOTONIC | COBRIDGE_VALID_KIND_SEQUENCE));
  // Staleness already detected stays; an offline device's values are stale.
  const bool is_stale = stale || stale_[node_id] || !online;
  out.online = online ? 1 : 0;
  out.stale = is_stale ? 1 : 0;
  out.nmt_state = nmt_state;
  if (is_stale) stale_[node_id] = true;
  count(samples_);
  return true;
}

bool FrameDecoder::make_command(std::uint8_t node_id, std::uint8_t kind, std::uint8_t status, std::uint32_t tag,
                                std::uint32_t abort_code, std::int64_t timestamp_ns, Sample& out) noexcept {
  if (!gateway_header(node_id, COBRIDGE_SAMPLE_COMMAND, timestamp_ns, out)) return false;
  out.valid = COBRIDGE_VALID_COMMAND | (out.valid & (COBRIDGE_VALID_RX_MONOTONIC | COBRIDGE_VALID_KIND_SEQUENCE));
  out.command_kind = kind;
  out.command_status = status;
  out.command_tag = tag;
  out.command_abort_code = abort_code;
  count(samples_);
  return true;
}

bool FrameDecoder::indexed(std::uint8_t node) noexcept {
  if (plans_[node].indexed) return true;
  count(unknown_node_);
  return false;
}

DecoderStats FrameDecoder::stats() const noexcept {
  return DecoderStats{frames_.load(std::memory_order_relaxed), samples_.load(std::memory_order_relaxed),
                      unknown_node_.load(std::memory_order_relaxed), bad_length_.load(std::memory_order_relaxed),
                      ignored_.load(std::memory_order_relaxed)};
}

}  // namespace cobridge::pipeline
