#include "cli/status_command.hpp"

#include "base/number_text.hpp"
#include "cli/control_client.hpp"
#include "cli/daemon_route.hpp"
#include "cli/json_value.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace cobridge::cli {
namespace {

// "2024-05-01T12:00:00.123Z" -> "2024-05-01 12:00:00Z"
std::string short_time(const Json& t) {
  if (t.type != Json::Type::string) return "-";
  std::string s = t.text;
  if (s.size() >= 19) {
    s[10] = ' ';
    s = s.substr(0, 19) + "Z";
  }
  return s;
}

// The gateway's line, then one per bus.
void print_summary(const Json& doc, const std::vector<Json>& buses) {
  std::printf("cobridged %s on %s, pid %lld, %s, started %s, config %s\n", doc["version"].str().c_str(),
              doc["gateway"].str().c_str(), doc["pid"].integer(), doc["ready"].boolean ? "ready" : "starting",
              short_time(doc["started"]).c_str(), doc["config"].str().c_str());
  std::printf("%zu bus%s, %lld/%lld devices operational\n\n", buses.size(), buses.size() == 1 ? "" : "es",
              doc["devices_operational"].integer(), doc["devices_total"].integer());
  for (const auto& b : buses) {
    const auto& c = b["counters"];
    std::printf("bus %s (%s): %s%s%s; rx %lld, tx %lld, error frames %lld, rx drops %lld, reopens %lld\n",
                b["name"].str().c_str(), b["interface"].str().c_str(), b["open"].boolean ? "open" : "CLOSED",
                b["last_bus_event"].str("").empty() ? "" : ", last event: ",
                b["last_bus_event"].str("").c_str(), c["rx_frames"].integer(), c["tx_frames"].integer(),
                c["error_frames"].integer(), c["rx_overflow_drops"].integer(), c["reopens"].integer());
    const auto& ctl = b["controller"];
    const std::string ctl_state = ctl.is_null() ? std::string() : ctl["state"].str("");
    if (!ctl_state.empty() && ctl_state != "error-active" && ctl_state != "unknown") {
      std::printf("  CAN controller %s (tx errors %lld, rx errors %lld, restarts %lld; from %s)\n",
                  ctl["state"].str().c_str(), ctl["tx_errors"].integer(), ctl["rx_errors"].integer(),
                  ctl["restarts"].integer(), ctl["source"].str("?").c_str());
    }
    const auto& r = b["redundancy"];
    if (!r.is_null()) {
      std::printf("  hot standby: %s, master node %lld, peer node %lld (%s, since %s)\n", r["role"].str().c_str(),
                  r["master_node"].integer(), r["peer_node"].integer(), r["cause"].str().c_str(),
                  short_time(r["since"]).c_str());
    }
  }
}

// One row per device, columns as wide as their widest cell (model names
// come from the EDS files), each followed by its last error.
void print_devices(const std::vector<Json>& buses) {
  using Row = std::vector<std::string>;
  std::vector<Row> table{{"BUS", "NODE", "NAME", "MODEL", "SERIAL", "STATE", "ONLINE", "SINCE", "LAST EMCY"}};
  std::vector<std::string> errors{""};
  for (const auto& b : buses) {
    for (const auto& d : b["devices"].items) {
      const auto& emcy = d["last_emcy"];
      std::string last_emcy = "-";
      if (!emcy.is_null()) last_emcy = hex(static_cast<std::uint16_t>(emcy["code"].integer()), 4) + " " + emcy["text"].str("");
      table.push_back({b["name"].str(), d["node_id"].str(), d["name"].str(), d["model"].str(),
                       d["identity"]["serial"].str(), d["state"].str(), d["online"].boolean ? "yes" : "no",
                       short_time(d["since"]), last_emcy});
      std::string notes = d["last_error"].str("");
      // A client set configured objects to other values; contested ones
      // wait for `cobridge acknowledge`.
      if (d["config_differs"].boolean) {
        std::string objects;
        for (const auto& r : d["drift"].items)
          objects += (objects.empty() ? "" : "; ") + r["text"].str("") + (r["contested"].boolean ? " CONTESTED" : "");
        notes += std::string(notes.empty() ? "" : "\n    ") + "configuration differs: " + objects;
        if (d["config_contested"].boolean)
          notes += "\n    contested: not written back until `cobridge acknowledge " + d["name"].str() + "`";
      }
      errors.push_back(std::move(notes));
    }
  }
  std::vector<std::size_t> width(table.front().size(), 0);
  for (const auto& row : table)
    for (std::size_t i = 0; i < row.size(); ++i) width[i] = std::max(width[i], row[i].size());
  std::printf("\n");
  for (std::size_t r = 0; r < table.size(); ++r) {
    std::string line;
    for (std::size_t i = 0; i < table[r].size(); ++i) {
      line += table[r][i];
      if (i + 1 < table[r].size()) line += std::string(width[i] - table[r][i].size() + 2, ' ');
    }
    std::printf("%s\n", line.c_str());
    if (errors[r].empty()) continue;
    // A last error comes first; "configuration differs" stands on its own line.
    const bool error_first = errors[r].rfind("configuration differs", 0) != 0;
    std::printf("    %s%s\n", error_first ? "last error: " : "", errors[r].c_str());
  }
  if (table.size() == 1) std::printf("(no devices)\n");
}

// Each bus's problems, then each bus's recent steps.
void print_problems_and_steps(const std::vector<Json>& buses) {
  for (const auto& b : buses) {
    if (!b["problems"].items.empty()) {
      std::printf("\nproblems on %s:\n", b["name"].str().c_str());
      for (const auto& p : b["problems"].items) std::printf("  - %s\n", p.str().c_str());
    }
  }
  for (const auto& b : buses) {
    if (b["steps"].items.empty()) continue;
    std::printf("\nsteps on %s (most recent last):\n", b["name"].str().c_str());
    std::printf("  %-28s %-16s %10s  %s\n", "STEP", "DEVICE", "MS", "AT");
    for (const auto& s : b["steps"].items)
      std::printf("  %-28s %-16s %10.1f  %s\n", s["step"].str().c_str(), s["device"].str().c_str(),
                  s["ms"].number, short_time(s["at"]).c_str());
  }
}

void print_table(const Json& doc) {
  const auto& buses = doc["buses"].items;
  print_summary(doc, buses);
  print_devices(buses);
  print_problems_and_steps(buses);
}

}  // namespace

int status(const StatusOptions& o) {
  const Result<std::string> answer = request(o.control, "status", o.timeout_ms);
  if (!answer.ok()) return report_failure("status", answer.error(), o.json);
  const auto doc = JsonParser(*answer).parse();
  if (!doc.ok() || doc->type != Json::Type::object) {
    return report_failure("status", Error(Errc::kInternal, std::string("the daemon's answer is not a JSON object: ") +
                                                         (doc.ok() ? "wrong type" : doc.error().message)), o.json);
  }
  if (!(*doc)["error"].is_null()) return report_failure("status", error_of_answer(*doc), o.json);
  if (o.json) {
    std::printf("%s\n", answer->c_str());
  } else {
    print_table(*doc);
  }
  return 0;
}

int commission(const CommissionOptions& o) {
  const std::string line = o.bus.empty() ? "commission" : "commission " + o.bus;
  const Result<std::string> answer = request(o.control, line, o.timeout_ms);
  if (!answer.ok()) return report_failure("commission", answer.error(), o.json);
  const auto doc = JsonParser(*answer).parse();
  if (!doc.ok() || doc->type != Json::Type::object) {
    return report_failure("commission", Error(Errc::kInternal, std::string("the daemon's answer is not a JSON object: ") +
                                                             (doc.ok() ? "wrong type" : doc.error().message)), o.json);
  }
  const bool ok = (*doc)["error"].is_null();
  if (o.json) {
    std::printf("%s\n", answer->c_str());
  } else if (ok) {
    std::string buses;
    for (const auto& b : (*doc)["buses"].items) buses += (buses.empty() ? "" : ", ") + b.str();
    std::printf("commissioning requested on %s; follow it with `cobridge status`\n", buses.c_str());
  }
  if (!ok) {
    const Error e = error_of_answer(*doc);
    if (!o.json) std::fprintf(stderr, "cobridge: commission: %s\n", e.to_string().c_str());
    return exit_code(e.kind);
  }
  return 0;
}

}  // namespace cobridge::cli
