#include "cli/scan_command.hpp"

#include "base/json_writer.hpp"
#include "base/number_text.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/lss_master.hpp"
#include "canopen/nmt.hpp"
#include "cli/bus_session.hpp"
#include "cli/control_client.hpp"
#include "cli/daemon_route.hpp"
#include "cli/json_value.hpp"
#include "device/device_catalog.hpp"
#include "sys/install_paths.hpp"

#include <array>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#ifndef COBRIDGE_SOURCE_DEVICE_DIR
#define COBRIDGE_SOURCE_DEVICE_DIR ""
#endif

namespace cobridge::cli {
namespace {

struct NodeReport {
  unsigned node = 0;
  std::string seen;                          // "boot-up", "heartbeat:<state>", "sdo"
  std::array<std::set<uint32_t>, 5> answers; // 0x1018 sub 1..4: every distinct value
  bool unconfigured = false;                 // found by Fastscan (node-ID FFh)
  unsigned assigned = 0;
  std::string model;
};

uint32_t value_of(const can::Frame& f) {
  return static_cast<uint32_t>(f.data[4]) | (static_cast<uint32_t>(f.data[5]) << 8) |
         (static_cast<uint32_t>(f.data[6]) << 16) | (static_cast<uint32_t>(f.data[7]) << 24);
}

// Sends `40 18 10 sub` to each node and collects every expedited answer for
// `window`; several different answers for one node mean several devices.
void probe_identity(BusSession& bus, const std::vector<unsigned>& nodes, uint8_t sub,
                    std::map<unsigned, NodeReport>& reports, unsigned window_ms) {
  for (unsigned n : nodes) {
    const auto req = can::Frame::make8(canopen::cob::kSdoRxBase + n, {0x40, 0x18, 0x10, sub, 0, 0, 0, 0});
    (void)bus.channel().send(req);
  }
  bus.listen(
      [&](const can::Frame& f, TimePoint) {
        if (f.len != 8 || f.id <= canopen::cob::kSdoTxBase || f.id > canopen::cob::kSdoTxBase + 127) return;
        if (f.data[1] != 0x18 || f.data[2] != 0x10 || f.data[3] != sub) return;
        if ((f.data[0] & 0xE3) != 0x43) return;  // expedited upload response with size
        auto& r = reports[f.id - canopen::cob::kSdoTxBase];
        r.node = f.id - canopen::cob::kSdoTxBase;
        if (r.seen.empty()) r.seen = "sdo";
        r.answers[sub].insert(value_of(f));
      },
      std::chrono::milliseconds(window_ms));
}

std::string model_name(const device::DeviceCatalog& catalog, uint32_t vendor, uint32_t product) {
  const auto candidates = catalog.candidates(vendor, product);
  if (candidates.empty()) return "";
  return candidates.front()->device_info.product_name;
}

std::string hex_or_clash(const std::set<uint32_t>& s) {
  if (s.empty()) return "?";
  if (s.size() > 1) return std::to_string(s.size()) + " answers";
  return hex(*s.begin(), 8);
}

// The daemon's discovery view of one bus (its status document's bus), as
// `scan --json` prints it.
void print_daemon_view_json(const Json& b) {
  JsonWriter w;
  w.begin_object().field("ok", true).field("via", "daemon").field("bus", b["name"].str()).key("devices").begin_array();
  for (const auto& d : b["devices"].items) {
    w.begin_object().key("node");
    if (d["node_id"].is_null()) {
      w.null();
    } else {
      w.value(d["node_id"].integer());
    }
    const Json& id = d["identity"];
    w.field("vendor", id["vendor"].integer()).field("product", id["product"].integer());
    w.field("revision", id["revision"].integer()).field("serial", id["serial"].integer());
    w.field("model", d["model"].str("")).field("name", d["name"].str("")).field("state", d["state"].str(""));
    w.end_object();
  }
  std::printf("%s\n", w.end_array().end_object().text().c_str());
}

void print_daemon_view_table(const Json& b, const std::string& iface) {
  std::printf("(cobridged owns %s: its discovery's view of bus %s)\n%-6s %-10s %-12s %-12s %-14s %s\n", iface.c_str(),
              b["name"].str().c_str(), "NODE", "SERIAL", "MODEL", "NAME", "STATE", "LAST ERROR");
  for (const auto& d : b["devices"].items)
    std::printf("%-6s %-10s %-12s %-12s %-14s %s\n", d["node_id"].str().c_str(), d["identity"]["serial"].str().c_str(),
                d["model"].str().c_str(), d["name"].str().c_str(), d["state"].str().c_str(),
                d["last_error"].str("").c_str());
}

}  // namespace

// A daemon serving `iface` already discovers that bus: its view is printed
// instead of a second master's probe. nullopt: no daemon owns the bus (or
// none answers). A control socket this user may not open is a failure
// (permission_denied): a daemon may own the bus.
std::optional<int> scan_via_daemon(const ScanOptions& o) {
  Error failure;
  bool owned = false;
  const std::string control = control_for(o.control, o.iface, owned, failure);
  if (failure) return report_failure("scan", failure, o.json);
  bool no_daemon = false;
  const Result<std::string> answer = request(control, "status", 3000, &no_daemon);
  // The daemon serving this interface could not be asked: no second master's probe.
  if (!answer.ok() && owned) return report_failure("scan", answer.error(), o.json);
  // A daemon this user may not ask could own the bus: no second master's probe.
  if (!answer.ok() && answer.error().kind == Errc::kPermissionDenied)
    return report_failure("scan", answer.error(), o.json);
  if (!answer.ok()) return std::nullopt;
  const auto doc = JsonParser(*answer).parse();
  if (!doc.ok()) return std::nullopt;
  for (const auto& b : (*doc)["buses"].items) {
    if (b["interface"].str("") != o.iface) continue;
    if (o.assign_from)
      return report_failure("scan", Error(Errc::kUnavailable, "cobridged owns this bus: `cobridge commission --bus " +
                                                                  b["name"].str() + "` assigns node-IDs through it",
                                          o.iface),
                            o.json);
    if (o.json) {
      print_daemon_view_json(b);
    } else {
      print_daemon_view_table(b, o.iface);
    }
    return 0;
  }
  return std::nullopt;
}

namespace {

// The floor of the learnt LSS waits (the daemon's lss_timeout_min_ms default).
constexpr std::chrono::milliseconds kLearntFloor{10};

// Listens for boot-ups and heartbeats, then asks every node-ID for its
// identity (0x1018:1, then 2..4 of the nodes that answered).
std::map<unsigned, NodeReport> probe_nodes(BusSession& bus, const ScanOptions& o) {
  std::map<unsigned, NodeReport> reports;
  bus.listen(
      [&](const can::Frame& f, TimePoint) {
        const auto ec = canopen::parse_error_control(f);
        if (!ec.ok()) return;
        const auto& m = ec.message;
        auto& r = reports[m.node];
        r.node = m.node;
        r.seen = m.is_boot_up ? "boot-up" : std::string("heartbeat:") + std::string(canopen::to_string(m.state));
      },
      std::chrono::milliseconds(o.listen_ms));

  std::vector<unsigned> all;
  for (unsigned n = 1; n <= 127; ++n) all.push_back(n);
  probe_identity(bus, all, 1, reports, o.sdo_timeout_ms);
  std::vector<unsigned> found;
  for (auto& [n, r] : reports)
    if (!r.answers[1].empty()) found.push_back(n);
  for (uint8_t sub = 2; sub <= 4; ++sub) probe_identity(bus, found, sub, reports, o.sdo_timeout_ms);

  return reports;
}

// Runs one LSS service of `m` to its result; false when it failed.
bool run_lss(BusSession& bus, canopen::LssMaster& m, std::error_code start,
             std::optional<canopen::LssMaster::Result>& r) {
  r.reset();
  if (start) return false;
  bus.run([&](const can::Frame& f, TimePoint now) { m.on_frame(f, now); },
          [&](TimePoint now) {
            auto d = m.process(now);
            if (!r) r = m.take_result();
            return d;
          },
          [&] { return r.has_value(); }, std::chrono::seconds(120));
  return r && !r->error;
}

// One non-configured device by CiA 305 Fastscan, or nullopt when none is
// left. A scan that fails otherwise than "nobody answered" (an answer later
// than the learnt wait) is begun again, twice at most, and said on stderr.
std::optional<canopen::LssAddress> fastscan_one(BusSession& bus, canopen::LssMaster& m) {
  std::optional<canopen::LssMaster::Result> r;
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (run_lss(bus, m, m.fastscan(canopen::Clock::now()), r)) return r->address;
    if (!r || r->error == make_error_code(canopen::LssErrc::kNotFound)) return std::nullopt;
    std::fprintf(stderr, "cobridge: scan: Fastscan failed (%s); scanning again\n", r->error.message().c_str());
  }
  return std::nullopt;
}

// CiA 305 Fastscan for non-configured devices; with --assign-from each one
// found gets the next free node-ID (reserved in `reports`), stored. Search
// steps wait as the daemon's do (docs/configuration.md, lss_timeout_ms and
// lss_timeout_min_ms); configure and store, which a device answers after
// writing its memory, wait up to a second.
std::vector<NodeReport> fastscan_unconfigured(BusSession& bus, const ScanOptions& o,
                                              std::map<unsigned, NodeReport>& reports) {
  std::vector<NodeReport> lss_found;
  const auto ceiling = std::chrono::milliseconds(o.lss_timeout_ms);
  canopen::LssMaster m(bus.channel(), canopen::LssMaster::Config{ceiling, std::min(ceiling, kLearntFloor)});
  canopen::LssMaster confirmed(bus.channel(), canopen::LssMaster::Config{std::chrono::milliseconds(1000), {}});
  unsigned next_id = o.assign_from;
  for (;;) {
    const auto found = fastscan_one(bus, m);
    if (!found) break;  // none (left)
    NodeReport nr;
    nr.unconfigured = true;
    nr.answers[1].insert(found->vendor);
    nr.answers[2].insert(found->product);
    nr.answers[3].insert(found->revision);
    nr.answers[4].insert(found->serial);
    if (o.assign_from == 0) {
      (void)m.switch_state_global(canopen::LssMode::kWaiting);
      lss_found.push_back(nr);
      break;
    }
    while (next_id <= 127 && reports.count(next_id) != 0) ++next_id;
    if (next_id > 127) {
      std::fprintf(stderr, "cobridge: scan: no free node-ID left from %u\n", o.assign_from);
      (void)m.switch_state_global(canopen::LssMode::kWaiting);
      break;
    }
    std::optional<canopen::LssMaster::Result> r;
    const bool ok =
        run_lss(bus, confirmed, confirmed.configure_node_id(static_cast<uint8_t>(next_id), canopen::Clock::now()), r) &&
        run_lss(bus, confirmed, confirmed.store_configuration(canopen::Clock::now()), r);
    (void)m.switch_state_global(canopen::LssMode::kWaiting);
    if (!ok) {
      std::fprintf(stderr, "cobridge: scan: assigning node-ID %u failed: %s\n", next_id,
                   r ? r->error.message().c_str() : "no answer");
      break;
    }
    nr.assigned = next_id;
    reports[next_id].node = next_id;  // reserve it
    reports[next_id].seen = "lss";
    lss_found.push_back(nr);
    ++next_id;
  }
  return lss_found;
}

bool clashes(const NodeReport& r) {
  return r.answers[1].size() > 1 || r.answers[2].size() > 1 || r.answers[3].size() > 1 || r.answers[4].size() > 1;
}

void print_json(const std::vector<NodeReport>& rows) {
  static constexpr const char* kNames[] = {"", "vendor", "product", "revision", "serial"};
  JsonWriter w;
  w.begin_array();
  for (const auto& r : rows) {
    w.begin_object().key("node");
    if (r.unconfigured) {
      w.null();
    } else {
      w.value(r.node);
    }
    w.field("seen", r.unconfigured ? std::string("fastscan") : r.seen).field("model", r.model);
    w.field("clash", clashes(r));
    for (std::size_t s = 1; s <= 4; ++s) {
      w.key(kNames[s]).begin_array();
      for (const std::uint32_t v : r.answers[s]) w.value(v);
      w.end_array();
    }
    if (r.assigned) w.field("assigned", r.assigned);
    w.end_object();
  }
  std::printf("%s\n", w.end_array().text().c_str());
}

void print_table(const std::vector<NodeReport>& rows, const std::string& iface) {
  std::printf("%-6s %-12s %-10s %-10s %-12s %-12s %-14s %s\n", "NODE", "VENDOR", "PRODUCT", "REVISION",
              "SERIAL", "MODEL", "SEEN", "NOTE");
  for (const auto& r : rows) {
    const bool clash = r.answers[1].size() > 1 || r.answers[2].size() > 1 || r.answers[3].size() > 1 ||
                       r.answers[4].size() > 1;
    std::string node = r.unconfigured ? "FFh" : std::to_string(r.node);
    std::string note = clash ? "CLASH: several devices on this node-ID" : "";
    if (r.assigned) note = "assigned node-ID " + std::to_string(r.assigned) + ", stored";
    if (r.unconfigured && !r.assigned) note = "non-configured (use --assign-from N)";
    if (!r.unconfigured && r.answers[1].empty()) note = "no SDO answer";
    std::printf("%-6s %-12s %-10s %-10s %-12s %-12s %-14s %s\n", node.c_str(),
                hex_or_clash(r.answers[1]).c_str(), hex_or_clash(r.answers[2]).c_str(),
                hex_or_clash(r.answers[3]).c_str(),
                r.answers[4].size() == 1 ? std::to_string(*r.answers[4].begin()).c_str()
                                         : hex_or_clash(r.answers[4]).c_str(),
                r.model.empty() ? "-" : r.model.c_str(), r.unconfigured ? "fastscan" : r.seen.c_str(),
                note.c_str());
  }
  if (rows.empty()) std::printf("(no device answered on %s)\n", iface.c_str());
}

}  // namespace

int scan(const ScanOptions& o) {
  if (const auto rc = scan_via_daemon(o)) return *rc;
  auto opened = BusSession::open(o.iface);
  if (!opened.ok()) return report_failure("scan", opened.error(), o.json);
  const std::unique_ptr<BusSession> bus = std::move(opened).value();
  device::DeviceCatalog catalog;
  {
    std::string dir = o.devices_dir;
    if (dir.empty()) dir = sys::installed_or(sys::InstallDir::devices, COBRIDGE_SOURCE_DEVICE_DIR).string();
    if (!dir.empty()) (void)catalog.load_directory(dir);
  }
  std::map<unsigned, NodeReport> reports = probe_nodes(*bus, o);
  std::vector<NodeReport> lss_found;
  if (o.fastscan) lss_found = fastscan_unconfigured(*bus, o, reports);

  std::vector<NodeReport> rows;
  for (auto& [n, r] : reports)
    if (r.seen != "lss") rows.push_back(r);
  for (auto& r : lss_found) rows.push_back(r);
  for (auto& r : rows)
    if (r.answers[1].size() == 1 && r.answers[2].size() == 1)
      r.model = model_name(catalog, *r.answers[1].begin(), *r.answers[2].begin());
  if (o.json)
    print_json(rows);
  else
    print_table(rows, o.iface);
  return 0;
}

}  // namespace cobridge::cli
