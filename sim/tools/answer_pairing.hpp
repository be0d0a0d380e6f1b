// AnswerPairing: pairs the answers of CANopen slaves with the requests they
// answer, from frames read off the bus with their kernel receive times, and
// keeps each answer's latency (answer time - request time). It is the logic
// of cobridge-sim-latency (answer_latency.cpp); it reads no socket itself.
//
// LSS (CiA 305 §8.3, master 0x7E5 -> slave 0x7E4): the master has one request
// on the bus at a time. An answer belongs to the latest request when its
// command specifier is the one that request asks for (switch selective 0x43
// -> 0x44, identify/Fastscan 0x46..0x4B/0x51 -> 0x4F, identify non-configured
// 0x4C -> 0x50, configure/inquire/store -> the same specifier). Any other
// answer is late (it answers an earlier request): counted `mismatched`, not
// measured, since its request can no longer be told. Every answer to one
// request is measured from that request (a Fastscan step is answered by
// every matching slave, and each answer is a slave's own).
//
// SDO (CiA 301 §7.2.4.3, client 0x600+n -> server 0x580+n): one pending
// request per node-ID; its answer closes it. An answer with no pending
// request is counted `mismatched`.
//
// Echo (cobridge-bus-echo, 0x7F0 -> 0x7F1): the same as one SDO node; the
// floor any answering process meets in the same run.
//
// Thread: the reader's only; nothing here is thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace cobridge::sim::tools {

struct LatencySummary {
  std::size_t count = 0;
  std::int64_t p50_ns = 0;
  std::int64_t p99_ns = 0;
  std::int64_t max_ns = 0;
};

// Nearest-rank percentiles (p50, p99) and the maximum of `latencies_ns`.
[[nodiscard]] LatencySummary summarize(std::vector<std::int64_t> latencies_ns);

struct ServiceCounts {
  std::uint64_t requests = 0;
  std::uint64_t answers = 0;     // measured answers
  std::uint64_t unanswered = 0;  // requests that got no answer before the next one (or the end)
  std::uint64_t mismatched = 0;  // answers that are not the latest request's (LSS: late)
  std::uint64_t downloads = 0;   // SDO: initiate download requests (CiA 301 ccs 1), the writes
  std::uint64_t repeats = 0;     // LSS: answers to a request already answered (measured too)
  std::vector<std::int64_t> latency_ns;
};

class AnswerPairing {
 public:
  // One classic CAN frame as read, `t_ns` its receive time.
  void on_frame(std::uint32_t id, const std::uint8_t* data, std::uint8_t len, std::int64_t t_ns);
  // Closes the requests still open (counted unanswered); call once at the end.
  void finish();

  [[nodiscard]] const ServiceCounts& lss() const noexcept { return lss_; }
  [[nodiscard]] const ServiceCounts& sdo() const noexcept { return sdo_; }
  [[nodiscard]] const ServiceCounts& echo() const noexcept { return echo_; }

 private:
  struct Pending {
    std::int64_t t_ns = 0;
    std::uint8_t cs = 0;
    bool open = false;
    bool answered = false;
  };
  void on_lss_request(std::uint8_t cs, std::int64_t t_ns);
  void on_lss_answer(std::uint8_t cs, std::int64_t t_ns);
  void on_sdo_request(std::uint8_t node, std::uint8_t cs, std::int64_t t_ns);
  void on_sdo_answer(std::uint8_t node, std::int64_t t_ns);
  static void on_request(ServiceCounts& c, Pending& p, std::int64_t t_ns);
  static void on_answer(ServiceCounts& c, Pending& p, std::int64_t t_ns);

  ServiceCounts lss_;
  ServiceCounts sdo_;
  ServiceCounts echo_;
  Pending echo_pending_;
  Pending lss_pending_;
  std::array<Pending, 128> sdo_pending_{};
};

}  // namespace cobridge::sim::tools
