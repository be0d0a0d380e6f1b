// Multi-gateway sequence bench (prints figures; not a test). A subscriber
// telling loss from silence at the full rate, on the host: two gateways ("bench-a",
// "bench-b"), each the real libcobridge_dds.so loaded through
// pipeline::PluginHost, 4 devices each, a TPDO every 1 ms per device and a
// heartbeat every 100 ms per device, numbered as the RX thread numbers them
// (sequence per device, kind_sequence per device and kind). A subscriber in
// another process (its own Cyclone instance: samples cross loopback) reads
// EncoderSample reliable keep-all and counts, per instance, samples and
// gaps (sequence_number != previous + 1).
//
// The UML end-to-end test (vcan_outputs_dds_multi_gateway) runs the real
// daemons, but UML's one CPU lets the simulators send only a few hundred
// TPDOs/s; this bench runs the DDS side at the 4 x 1 kHz per gateway the
// target names.
//
// Usage: cobridge_bench_dds_multi_gateway [seconds = 10] [reliable|best-effort]
//                                         [auto|writer-thread|dispatcher]
#include "bench_time.hpp"
#include "pipeline/plugin_host.hpp"
#include "pipeline/sample.hpp"

#include "cobridge_idl/cobridge.h"

#include <dds/dds.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

using namespace cobridge;

namespace {

using namespace cobridge::bench;  // bench_time.hpp: clocks and percentiles

constexpr unsigned kGateways = 2, kDevices = 4;
constexpr std::uint32_t kTake = 256;


struct Count {
  std::uint64_t samples = 0, gaps = 0, lost = 0;
  std::uint32_t last = 0;
};

// The subscriber: runs until `seconds` + 5 s have passed, then prints.
int subscriber(std::uint32_t domain, bool reliable, double seconds) {
  const dds_entity_t pp = dds_create_participant(domain, nullptr, nullptr);
  const dds_entity_t t = dds_create_topic(pp, &cobridge_EncoderSample_desc, "EncoderSample", nullptr, nullptr);
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_SECS(1));
  dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t r = dds_create_reader(pp, t, q, nullptr);
  dds_delete_qos(q);
  const dds_entity_t ws = dds_create_waitset(pp);
  dds_waitset_attach(ws, dds_create_readcondition(r, DDS_ANY_STATE), 0);
  std::map<std::tuple<std::string, int, int>, Count> counts;
  const std::uint64_t end = mono_ns() + static_cast<std::uint64_t>((seconds + 5.0) * 1e9);
  while (mono_ns() < end) {
    (void)dds_waitset_wait(ws, nullptr, 0, DDS_MSECS(100));
    for (;;) {
      void* buf[kTake] = {};
      dds_sample_info_t info[kTake];
      const int n = dds_take(r, buf, info, kTake, kTake);
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        if (!info[i].valid_data) continue;
        const auto& s = *static_cast<const cobridge_EncoderSample*>(buf[i]);
        Count& c = counts[{s.gateway_id, s.bus, s.node_id}];
        if (c.samples != 0 && s.sequence_number != c.last + 1u) {
          ++c.gaps;
          c.lost += s.sequence_number - c.last - 1u;
        }
        c.last = s.sequence_number;
        ++c.samples;
      }
      dds_return_loan(r, buf, n);
    }
  }
  std::uint64_t total = 0, gaps = 0;
  for (const auto& [k, c] : counts) {
    std::printf("  %s/%d/%d: %" PRIu64 " samples, %" PRIu64 " gaps (%" PRIu64 " lost)\n", std::get<0>(k).c_str(),
                std::get<1>(k), std::get<2>(k), c.samples, c.gaps, c.lost);
    total += c.samples;
    gaps += c.gaps;
  }
  std::printf("subscriber: %zu instances, %" PRIu64 " samples, %" PRIu64 " gaps\n", counts.size(), total, gaps);
  dds_delete(pp);
  return 0;
}

// One gateway: a plugin instance with 4 devices and their counters.
struct Gateway {
  std::unique_ptr<pipeline::PluginHost> host;
  std::uint32_t seq[kDevices] = {}, tpdo_seq[kDevices] = {}, hb_seq[kDevices] = {};
};

cobridge_sample sample(Gateway& g, unsigned d, std::uint8_t kind, std::uint64_t now) {
  cobridge_sample s{};
  s.kind = kind;
  s.device_index = static_cast<std::uint16_t>(d);
  s.bus_index = 0;
  s.node_id = static_cast<std::uint8_t>(10 + d);
  s.sequence = ++g.seq[d];
  s.kind_sequence = kind == COBRIDGE_SAMPLE_TPDO ? ++g.tpdo_seq[d] : ++g.hb_seq[d];
  s.rx_timestamp_ns = s.publish_timestamp_ns = now;
  s.valid = COBRIDGE_VALID_KIND_SEQUENCE;
  if (kind == COBRIDGE_SAMPLE_TPDO) {
    s.position = static_cast<std::int64_t>(s.kind_sequence);
    s.valid |= COBRIDGE_VALID_POSITION;
  } else {
    s.nmt_state = COBRIDGE_NMT_OPERATIONAL;
    s.valid |= COBRIDGE_VALID_NMT_STATE;
  }
  return s;
}

int gateways(std::uint32_t domain, const std::string& config, double seconds) {
  const std::filesystem::path plugin = COBRIDGE_DDS_PLUGIN_FILE;
  Gateway gw[kGateways];
  for (unsigned g = 0; g < kGateways; ++g) {
    gw[g].host = std::make_unique<pipeline::PluginHost>(pipeline::PluginHost::Options{
        plugin.parent_path(), g == 0 ? "bench-a" : "bench-b",
        [](pipeline::LogLevel, std::string_view, std::string_view m) {
          std::fprintf(stderr, "  plugin: %.*s\n", static_cast<int>(m.size()), m.data());
        }});
    const Error err = gw[g].host->load({"dds", "dds", plugin, "domain = " + std::to_string(domain) + "\n" + config});
    if (err ||
        !gw[g].host->start_all().empty()) {
      std::fprintf(stderr, "plugin start failed: %s\n", err.message.c_str());
      return 1;
    }
    for (unsigned d = 0; d < kDevices; ++d) {
      cobridge_device_info info{};
      info.struct_size = sizeof info;
      info.device_index = static_cast<std::uint16_t>(d);
      info.node_id = static_cast<std::uint8_t>(10 + d);
      info.change = COBRIDGE_DEVICE_ADDED;
      const std::string name = "enc" + std::to_string(d);
      info.name = name.c_str();
      info.bus_name = info.model = info.family = info.position_unit = "";
      gw[g].host->announce(info);
    }
  }
  sleep(2);  // discovery
  const auto ticks = static_cast<std::uint64_t>(seconds * 1000);
  const std::uint64_t t0 = mono_ns();
  std::vector<cobridge_sample> batch;
  for (std::uint64_t k = 0; k < ticks; ++k) {
    sleep_until_mono(t0 + k * 1000000ull);
    const std::uint64_t now = static_cast<std::uint64_t>(time(nullptr)) * 1000000000ull;
    for (Gateway& g : gw) {  // each gateway's dispatcher hands over one ms of its bus
      batch.clear();
      for (unsigned d = 0; d < kDevices; ++d) {
        batch.push_back(sample(g, d, COBRIDGE_SAMPLE_TPDO, now));
        if (k % 100 == d) batch.push_back(sample(g, d, COBRIDGE_SAMPLE_HEARTBEAT, now));
      }
      g.host->deliver(batch);
    }
  }
  std::printf("gateways: %u x %u devices, %" PRIu64 " TPDOs and %" PRIu64 " heartbeats per device in %.1f s\n",
              kGateways, kDevices, ticks, (ticks + 99) / 100, static_cast<double>(mono_ns() - t0) / 1e9);
  sleep(2);  // the reliable backlog
  for (Gateway& g : gw) g.host->stop_all();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const std::string rel = argc > 2 ? argv[2] : "reliable";
  const std::string path = argc > 3 ? argv[3] : "auto";
  if (seconds <= 0 || (rel != "reliable" && rel != "best-effort") ||
      (path != "auto" && path != "writer-thread" && path != "dispatcher")) {
    std::fprintf(stderr, "usage: %s [seconds] [reliable|best-effort] [auto|writer-thread|dispatcher]\n", argv[0]);
    return 2;
  }
  setvbuf(stdout, nullptr, _IOLBF, 0);
  setenv("CYCLONEDDS_URI",
         "<General><Interfaces><NetworkInterface name=\"lo\" multicast=\"true\"/></Interfaces></General>"
         "<Internal><Watermarks><WhcHigh>64MB</WhcHigh></Watermarks></Internal>",
         0);
  const std::uint32_t domain = 100u + static_cast<std::uint32_t>(getpid()) % 40u;
  const pid_t child = fork();
  if (child == 0) _exit(subscriber(domain, rel == "reliable", seconds + 2.0));
  std::printf("multi-gateway bench: %s samples, sample_path %s, domain %u\n", rel.c_str(), path.c_str(), domain);
  const int rc = gateways(domain,
                          "sample_reliability = \"" + rel + "\"\nsample_depth = 10000\nsample_path = \"" + path + "\"\n",
                          seconds);
  int status = 0;
  waitpid(child, &status, 0);
  return rc;
}
