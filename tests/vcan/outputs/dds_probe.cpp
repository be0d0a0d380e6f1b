// cobridge_dds_probe: a DDS subscriber for the multi-gateway and security
// end-to-end tests (test_dds_multi_gateway.py, test_dds_security.py),
// written as a cell controller would: it reads EncoderSample (reliable,
// keep-all), DeviceStatus, GatewayStatus and EncoderEvent of every
// gateway in the domain and prints what a subscriber can tell, one JSON
// object per line on stdout:
//   {"ev":"gateway","t":ns,"gateway_id":..,"state":"alive|disposed|no_writers",
//    "devices":n,"devices_online":n,"duplicate":b,"incarnation":n}
//                       every GatewayStatus sample or instance-state change
//   {"ev":"sample_instance","t":ns,"gateway_id":..,"bus":b,"node":n,"state":..}
//                       an EncoderSample instance turning not-alive / alive
//   {"ev":"status","t":ns,"gateway_id":..,"bus":b,"node":n,"online":b}
//                       a DeviceStatus whose online flag changed
//   {"ev":"device","gateway_id":..,"bus":b,"node":n,"samples":N,"gaps":G,
//    "lost":L,"repeats":R,"first":s,"last":s}
//                       per EncoderSample instance, when the probe exits
//   {"ev":"event","t":ns,"gateway_id":..,"bus":b,"node":n,"code":c}
//                       every EncoderEvent
//   {"ev":"refused","topic":..,"error":..}
//                       a topic or reader DDS Security did not allow (the
//                       probe goes on without it)
//   {"ev":"totals","samples":N,"statuses":N,"events":N,"gateways":N}
//                       valid samples taken per topic, when the probe exits
//   {"ev":"switch","t":ns,"gateway_id":..,"bus":b,"node":n,"gap_ms":x,"first":s}
//                       an EncoderSample instance's samples now come from
//                       another writer (a hot-standby pair's failover):
//                       gap_ms since the previous writer's last sample,
//                       first = the new writer's first sequence number
// With --exclusive 1 the data readers ask for EXCLUSIVE ownership, as a
// subscriber of a hot-standby pair does (docs/dds.md); "device" lines are
// then per writer, so a failover is not counted as a gap.
// Exits after --seconds or when the file --stop-file exists. Timestamps are
// CLOCK_REALTIME ns when the probe took the sample.
//
// DDS Security (docs/dds.md, "Security"; test_dds_security.py): with
// --security-dir DIR --identity NAME the participant is created with the
// files scripts/dds-test-ca made for NAME in DIR, set here as a subscriber
// written independently of the gateway would set them (the dds.sec.*
// participant properties of Cyclone DDS 0.10); without them it is a plain
// participant.
//
// Gaps: consecutive samples of one instance whose sequence_number is not the
// previous + 1 (wrap included); a repeat (same number: the stale
// re-publication) is counted apart. With per-topic numbering a gap is a lost
// sample, so the test asserts gaps == 0.
#include "cobridge_idl/cobridge.h"

#include <dds/dds.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <thread>
#include <tuple>

namespace {

std::uint64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

const char* state_name(dds_instance_state_t s) {
  switch (s) {
    case DDS_IST_ALIVE: return "alive";
    case DDS_NOT_ALIVE_DISPOSED_INSTANCE_STATE: return "disposed";
    default: return "no_writers";
  }
}

struct Device {
  std::uint64_t samples = 0, gaps = 0, lost = 0, repeats = 0;
  std::uint32_t first = 0, last = 0;
};
using Key = std::tuple<std::string, int, int>;
// Per writer: a hot-standby pair's two gateways write one instance.
using WriterKey = std::tuple<std::string, int, int, dds_instance_handle_t>;
struct Writer {
  dds_instance_handle_t handle = 0;
  std::uint64_t last_t = 0;
  dds_instance_state_t state = DDS_IST_ALIVE;
};

struct Options {
  std::uint32_t domain = 0;
  double seconds = 60;
  std::string stop_file;
  std::string security_dir, identity;
  bool exclusive = false;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--domain") o.domain = static_cast<std::uint32_t>(std::atoi(argv[i + 1]));
    if (k == "--seconds") o.seconds = std::atof(argv[i + 1]);
    if (k == "--stop-file") o.stop_file = argv[i + 1];
    if (k == "--security-dir") o.security_dir = argv[i + 1];
    if (k == "--identity") o.identity = argv[i + 1];
    if (k == "--exclusive") o.exclusive = std::atoi(argv[i + 1]) != 0;
  }
  return o;
}

// The participant QoS of a secured subscriber: Cyclone's three builtin
// plugins by full path (Debian keeps them off the search path) and the
// identity's files as file: URIs.
dds_qos_t* security_qos(const Options& o) {
  dds_qos_t* q = dds_create_qos();
  const std::string lib = COBRIDGE_DDS_SECURITY_PLUGIN_DIR, dir = o.security_dir + "/";
  const auto set = [q](const char* name, const std::string& value) { dds_qset_prop(q, name, value.c_str()); };
  set("dds.sec.auth.library.path", lib + "/libdds_security_auth.so");
  set("dds.sec.auth.library.init", "init_authentication");
  set("dds.sec.auth.library.finalize", "finalize_authentication");
  set("dds.sec.access.library.path", lib + "/libdds_security_ac.so");
  set("dds.sec.access.library.init", "init_access_control");
  set("dds.sec.access.library.finalize", "finalize_access_control");
  set("dds.sec.crypto.library.path", lib + "/libdds_security_crypto.so");
  set("dds.sec.crypto.library.init", "init_crypto");
  set("dds.sec.crypto.library.finalize", "finalize_crypto");
  set("dds.sec.auth.identity_ca", "file:" + dir + "identity_ca.pem");
  set("dds.sec.auth.identity_certificate", "file:" + dir + o.identity + ".pem");
  set("dds.sec.auth.private_key", "file:" + dir + o.identity + "_key.pem");
  set("dds.sec.access.permissions_ca", "file:" + dir + "permissions_ca.pem");
  set("dds.sec.access.governance", "file:" + dir + "governance.p7s");
  set("dds.sec.access.permissions", "file:" + dir + o.identity + "_permissions.p7s");
  return q;
}

// A reader, or 0 when DDS Security refused its topic or the reader itself
// (reported as a "refused" line); any other failure ends the probe.
dds_entity_t make_reader(dds_entity_t pp, const dds_topic_descriptor_t* type, const char* name, bool keep_all,
                         bool transient, bool exclusive = false) {
  const dds_entity_t topic = dds_create_topic(pp, type, name, nullptr, nullptr);
  dds_entity_t r = topic;
  if (topic > 0) {
    dds_qos_t* q = dds_create_qos();
    dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(q, keep_all ? DDS_HISTORY_KEEP_ALL : DDS_HISTORY_KEEP_LAST, 16);
    dds_qset_durability(q, transient ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    if (exclusive) dds_qset_ownership(q, DDS_OWNERSHIP_EXCLUSIVE);
    r = dds_create_reader(pp, topic, q, nullptr);
    dds_delete_qos(q);
  }
  if (r == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) {
    std::printf("{\"ev\":\"refused\",\"topic\":\"%s\",\"error\":\"%s\"}\n", name, dds_strretcode(r));
    return 0;
  }
  if (r < 0) {
    std::fprintf(stderr, "probe: reader %s: %s\n", name, dds_strretcode(r));
    std::exit(2);
  }
  return r;
}

// Valid samples taken, per topic (the "totals" line).
struct Totals {
  std::uint64_t samples = 0, statuses = 0, events = 0, gateways = 0;
};
Totals g_totals;

constexpr std::uint32_t kTake = 256;  // the same on every take of a reader
// Takes per reader per wake-up: a reader that keeps up with 8 000 samples/s
// must not starve the others (status and liveliness are judged in ms).
constexpr int kRounds = 4;

// An invalid sample (an instance's state change: disposed, no writers) has
// only its key members set: the gateway's id is looked up by gateway_key
// from the valid samples seen before.
std::map<unsigned long long, std::string> g_ids;
const char* gateway_id(unsigned long long key, const char* id, bool valid) {
  if (valid && id != nullptr) return g_ids.insert_or_assign(key, id).first->second.c_str();
  const auto it = g_ids.find(key);
  return it != g_ids.end() ? it->second.c_str() : "?";
}

// How late EncoderSamples arrive, per gateway, printed every 500 ms as
//   {"ev":"lag","t":ns,"gateway_id":..,"rx_ms":max,"pub_ms":max,"n":samples}
// rx_ms: probe time - the frame's kernel receive time; pub_ms: probe time -
// the gateway dispatcher's hand-out time. Shows a backlog building up.
struct Lag {
  std::uint64_t since = 0, rx = 0, pub = 0, n = 0;
};
std::map<std::string, Lag> g_lag;
void note_lag(const char* gw, std::uint64_t t, const cobridge_EncoderSample& s) {
  Lag& l = g_lag[gw];
  if (l.since == 0) l.since = t;
  if (t > s.rx_timestamp_ns) l.rx = std::max<std::uint64_t>(l.rx, t - s.rx_timestamp_ns);
  if (t > s.publish_timestamp_ns) l.pub = std::max<std::uint64_t>(l.pub, t - s.publish_timestamp_ns);
  ++l.n;
  if (t - l.since < 500'000'000ull) return;
  std::printf("{\"ev\":\"lag\",\"t\":%llu,\"gateway_id\":\"%s\",\"rx_ms\":%.1f,\"pub_ms\":%.1f,\"n\":%llu}\n",
              static_cast<unsigned long long>(t), gw, static_cast<double>(l.rx) / 1e6, static_cast<double>(l.pub) / 1e6,
              static_cast<unsigned long long>(l.n));
  l = Lag{};
}
// Takes from `reader` until it is empty (at most kRounds batches of kTake);
// `each` sees every sample, valid or not, with its info and the batch's time.
template <typename T, typename F>
void take_all(dds_entity_t reader, F&& each) {
  for (int round = 0; round < kRounds; ++round) {
    void* buf[kTake] = {};
    dds_sample_info_t info[kTake];
    const int n = dds_take(reader, buf, info, kTake, kTake);
    if (n <= 0) return;
    const std::uint64_t t = now_ns();
    for (int i = 0; i < n; ++i) each(*static_cast<const T*>(buf[i]), info[i], t);
    dds_return_loan(reader, buf, n);
  }
}

// Prints a "switch" line when the instance's samples come from another writer.
void note_writer(Writer& w, const Key& k, dds_instance_handle_t h, std::uint64_t t, std::uint32_t seq) {
  if (w.handle != 0 && w.handle != h) {
    std::printf("{\"ev\":\"switch\",\"t\":%llu,\"gateway_id\":\"%s\",\"bus\":%d,\"node\":%d,\"gap_ms\":%.1f,"
                "\"first\":%u}\n",
                static_cast<unsigned long long>(t), std::get<0>(k).c_str(), std::get<1>(k), std::get<2>(k),
                static_cast<double>(t - w.last_t) / 1e6, seq);
  }
  w.handle = h;
  w.last_t = t;
}

void take_samples(dds_entity_t reader, std::map<WriterKey, Device>& devices, std::map<Key, Writer>& writers) {
  take_all<cobridge_EncoderSample>(reader, [&](const auto& s, const dds_sample_info_t& info, std::uint64_t t) {
    const char* gw = gateway_id(s.gateway_key, s.gateway_id, info.valid_data);
    const Key k{gw, s.bus, s.node_id};
    Writer& w = writers[k];
    if (info.instance_state != w.state) {
      w.state = info.instance_state;
      std::printf("{\"ev\":\"sample_instance\",\"t\":%llu,\"gateway_id\":\"%s\",\"bus\":%d,\"node\":%d,"
                  "\"state\":\"%s\"}\n",
                  static_cast<unsigned long long>(t), gw, s.bus, s.node_id, state_name(w.state));
    }
    if (!info.valid_data) return;
    note_writer(w, k, info.publication_handle, t, s.sequence_number);
    ++g_totals.samples;
    note_lag(gw, t, s);
    Device& d = devices[WriterKey{gw, s.bus, s.node_id, info.publication_handle}];
    if (d.samples == 0) {
      d.first = s.sequence_number;
    } else if (s.sequence_number == d.last) {
      ++d.repeats;
    } else if (s.sequence_number != d.last + 1u) {
      ++d.gaps;
      d.lost += s.sequence_number - d.last - 1u;
    }
    d.last = s.sequence_number;
    ++d.samples;
  });
}

void take_gateways(dds_entity_t reader) {
  take_all<cobridge_GatewayStatus>(reader, [&](const auto& s, const dds_sample_info_t& info, std::uint64_t t) {
    const bool v = info.valid_data;
    if (v) ++g_totals.gateways;
    std::printf("{\"ev\":\"gateway\",\"t\":%llu,\"gateway_id\":\"%s\",\"state\":\"%s\",\"valid\":%s,"
                "\"devices\":%d,\"devices_online\":%d,\"buses\":%d,\"buses_online\":%d,\"duplicate\":%s,"
                "\"incarnation\":%llu,\"pid\":%u,\"upd\":%llu,\"node\":%d,\"role\":\"%s\",\"master\":%d}\n",
                static_cast<unsigned long long>(t), gateway_id(s.gateway_key, s.gateway_id, v),
                state_name(info.instance_state), v ? "true" : "false", v ? s.devices : -1,
                v ? s.devices_online : -1, v ? s.buses : -1, v ? s.buses_online : -1,
                v && s.duplicate_id ? "true" : "false", static_cast<unsigned long long>(v ? s.incarnation : 0),
                v ? s.pid : 0u, static_cast<unsigned long long>(v ? s.updated_ns : 0), v ? s.redundancy_node : 0,
                v && s.role != nullptr ? s.role : "", v ? s.master_node : 0);
  });
}

void take_status(dds_entity_t reader, std::map<Key, int>& online) {
  take_all<cobridge_DeviceStatus>(reader, [&](const auto& s, const dds_sample_info_t& info, std::uint64_t t) {
    if (!info.valid_data) return;
    ++g_totals.statuses;
    const char* gw = gateway_id(s.gateway_key, s.gateway_id, true);
    int& o = online.try_emplace(Key{gw, s.bus, s.node_id}, -1).first->second;
    if (o == static_cast<int>(s.online)) return;
    o = s.online;
    std::printf("{\"ev\":\"status\",\"t\":%llu,\"gateway_id\":\"%s\",\"bus\":%d,\"node\":%d,\"online\":%s,"
                "\"upd\":%llu}\n",
                static_cast<unsigned long long>(t), gw, s.bus, s.node_id, s.online ? "true" : "false",
                static_cast<unsigned long long>(s.updated_ns));
  });
}

void take_events(dds_entity_t reader) {
  take_all<cobridge_EncoderEvent>(reader, [&](const auto& e, const dds_sample_info_t& info, std::uint64_t t) {
    if (!info.valid_data) return;
    ++g_totals.events;
    std::printf("{\"ev\":\"event\",\"t\":%llu,\"gateway_id\":\"%s\",\"bus\":%d,\"node\":%d,\"code\":%u}\n",
                static_cast<unsigned long long>(t), gateway_id(e.gateway_key, e.gateway_id, true), e.bus, e.node_id,
                static_cast<unsigned>(e.code));
  });
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  dds_qos_t* pqos = o.security_dir.empty() ? nullptr : security_qos(o);
  const dds_entity_t pp = dds_create_participant(static_cast<dds_domainid_t>(o.domain), pqos, nullptr);
  if (pqos != nullptr) dds_delete_qos(pqos);
  if (pp < 0) {
    std::fprintf(stderr, "probe: participant: %s\n", dds_strretcode(pp));
    return 2;
  }
  const bool x = o.exclusive;
  const dds_entity_t samples = make_reader(pp, &cobridge_EncoderSample_desc, "EncoderSample", true, false, x);
  const dds_entity_t status = make_reader(pp, &cobridge_DeviceStatus_desc, "DeviceStatus", false, true, x);
  const dds_entity_t gateways = make_reader(pp, &cobridge_GatewayStatus_desc, "GatewayStatus", false, true);
  const dds_entity_t events = make_reader(pp, &cobridge_EncoderEvent_desc, "EncoderEvent", true, false, x);
  // One wait set over the readers: the probe wakes on data or on an
  // instance-state change (liveliness lost), not on a poll interval.
  const dds_entity_t ws = dds_create_waitset(pp);
  for (const dds_entity_t r : {samples, status, gateways, events}) {
    if (r == 0) continue;  // refused by DDS Security
    const dds_entity_t rc = dds_create_readcondition(r, DDS_ANY_STATE);
    dds_waitset_attach(ws, rc, r);
  }
  std::printf("{\"ev\":\"ready\",\"t\":%llu}\n", static_cast<unsigned long long>(now_ns()));
  std::fflush(stdout);
  std::map<WriterKey, Device> devices;
  std::map<Key, Writer> writers;
  std::map<Key, int> online;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (!o.stop_file.empty() && ::access(o.stop_file.c_str(), F_OK) == 0) break;
    (void)dds_waitset_wait(ws, nullptr, 0, DDS_MSECS(50));
    if (samples != 0) take_samples(samples, devices, writers);
    if (status != 0) take_status(status, online);
    if (gateways != 0) take_gateways(gateways);
    if (events != 0) take_events(events);
    std::fflush(stdout);
  }
  if (samples != 0) take_samples(samples, devices, writers);
  for (const auto& [k, d] : devices) {
    std::printf("{\"ev\":\"device\",\"gateway_id\":\"%s\",\"bus\":%d,\"node\":%d,\"samples\":%llu,"
                "\"gaps\":%llu,\"lost\":%llu,\"repeats\":%llu,\"first\":%u,\"last\":%u}\n",
                std::get<0>(k).c_str(), std::get<1>(k), std::get<2>(k), static_cast<unsigned long long>(d.samples),
                static_cast<unsigned long long>(d.gaps), static_cast<unsigned long long>(d.lost),
                static_cast<unsigned long long>(d.repeats), d.first, d.last);
  }
  std::printf("{\"ev\":\"totals\",\"samples\":%llu,\"statuses\":%llu,\"events\":%llu,\"gateways\":%llu}\n",
              static_cast<unsigned long long>(g_totals.samples), static_cast<unsigned long long>(g_totals.statuses),
              static_cast<unsigned long long>(g_totals.events), static_cast<unsigned long long>(g_totals.gateways));
  std::fflush(stdout);
  dds_delete(pp);
  return 0;
}
