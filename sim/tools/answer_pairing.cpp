#include "answer_pairing.hpp"

#include <algorithm>

namespace cobridge::sim::tools {

namespace {

constexpr std::uint32_t kLssMasterToSlave = 0x7E5;
constexpr std::uint32_t kLssSlaveToMaster = 0x7E4;
constexpr std::uint32_t kSdoRequestBase = 0x600;  // + node-ID, client -> server
constexpr std::uint32_t kSdoAnswerBase = 0x580;   // + node-ID, server -> client
constexpr std::uint32_t kEchoPing = 0x7F0;        // cobridge-bus-echo
constexpr std::uint32_t kEchoAnswer = 0x7F1;

// Whether an LSS answer with specifier `answer` answers a request with
// specifier `request` (CiA 305 §8.3.2-8.3.5).
bool answers(std::uint8_t answer, std::uint8_t request) noexcept {
  switch (answer) {
    case 0x44: return request == 0x43;                                    // switch state selective
    case 0x4F: return request == 0x51 || (request >= 0x46 && request <= 0x4B);  // Fastscan, identify remote
    case 0x50: return request == 0x4C;                                    // identify non-configured
    default: return answer == request;  // configure node-ID/bit timing, store, inquire identity/node-ID
  }
}

std::int64_t rank(const std::vector<std::int64_t>& sorted, unsigned percent) noexcept {
  // Nearest rank: the smallest value with at least `percent` % of the values at or below it.
  const std::size_t n = sorted.size();
  const std::size_t r = (n * percent + 99) / 100;
  return sorted[std::max<std::size_t>(r, 1) - 1];
}

}  // namespace

LatencySummary summarize(std::vector<std::int64_t> latencies_ns) {
  LatencySummary s;
  s.count = latencies_ns.size();
  if (s.count == 0) return s;
  std::sort(latencies_ns.begin(), latencies_ns.end());
  s.p50_ns = rank(latencies_ns, 50);
  s.p99_ns = rank(latencies_ns, 99);
  s.max_ns = latencies_ns.back();
  return s;
}

void AnswerPairing::on_frame(std::uint32_t id, const std::uint8_t* data, std::uint8_t len, std::int64_t t_ns) {
  if (len == 0) return;
  const auto node = [](std::uint32_t offset) { return static_cast<std::uint8_t>(offset); };
  if (id == kLssMasterToSlave) on_lss_request(data[0], t_ns);
  else if (id == kLssSlaveToMaster) on_lss_answer(data[0], t_ns);
  else if (id == kEchoPing) on_request(echo_, echo_pending_, t_ns);
  else if (id == kEchoAnswer) on_answer(echo_, echo_pending_, t_ns);
  else if (id > kSdoRequestBase && id < kSdoRequestBase + 128) on_sdo_request(node(id - kSdoRequestBase), data[0], t_ns);
  else if (id > kSdoAnswerBase && id < kSdoAnswerBase + 128) on_sdo_answer(node(id - kSdoAnswerBase), t_ns);
}

void AnswerPairing::on_lss_request(std::uint8_t cs, std::int64_t t_ns) {
  if (lss_pending_.open && !lss_pending_.answered) ++lss_.unanswered;
  ++lss_.requests;
  lss_pending_ = Pending{t_ns, cs, true, false};
}

void AnswerPairing::on_lss_answer(std::uint8_t cs, std::int64_t t_ns) {
  if (!lss_pending_.open || !answers(cs, lss_pending_.cs)) {
    ++lss_.mismatched;
    return;
  }
  if (lss_pending_.answered) ++lss_.repeats;
  lss_pending_.answered = true;
  ++lss_.answers;
  lss_.latency_ns.push_back(t_ns - lss_pending_.t_ns);
}

void AnswerPairing::on_request(ServiceCounts& c, Pending& p, std::int64_t t_ns) {
  if (p.open) ++c.unanswered;
  ++c.requests;
  p = Pending{t_ns, 0, true, false};
}

void AnswerPairing::on_answer(ServiceCounts& c, Pending& p, std::int64_t t_ns) {
  if (!p.open) {
    ++c.mismatched;
    return;
  }
  p.open = false;
  ++c.answers;
  c.latency_ns.push_back(t_ns - p.t_ns);
}

void AnswerPairing::on_sdo_request(std::uint8_t node, std::uint8_t cs, std::int64_t t_ns) {
  if ((cs & 0xE0) == 0x20) ++sdo_.downloads;
  on_request(sdo_, sdo_pending_[node], t_ns);
}

void AnswerPairing::on_sdo_answer(std::uint8_t node, std::int64_t t_ns) { on_answer(sdo_, sdo_pending_[node], t_ns); }

void AnswerPairing::finish() {
  if (lss_pending_.open && !lss_pending_.answered) ++lss_.unanswered;
  lss_pending_.open = false;
  for (Pending& p : sdo_pending_) {
    if (p.open) ++sdo_.unanswered;
    p.open = false;
  }
  if (echo_pending_.open) ++echo_.unanswered;
  echo_pending_.open = false;
}

}  // namespace cobridge::sim::tools
