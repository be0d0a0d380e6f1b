#include "cli/why_command.hpp"

#include "base/error.hpp"
#include "base/json_writer.hpp"
#include "cli/daemon_route.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace cobridge::cli {
namespace {

// "operational -> offline: ..." enters "offline": a state event's target.
bool enters(const Json& event, std::string_view state) {
  if (event["kind"].str("") != "state") return false;
  const std::string& text = event["text"].text;
  const std::size_t arrow = text.find(" -> ");
  if (arrow == std::string::npos) return false;
  const std::string_view rest = std::string_view(text).substr(arrow + 4);
  return rest.substr(0, rest.find(':')) == state;
}

// The device named `wanted` ("name" or "bus:node") in the status document,
// and its bus.
const Json* find_device(const Json& doc, const std::string& wanted, std::string& known, const Json*& bus_of) {
  for (const auto& bus : doc["buses"].items) {
    for (const auto& d : bus["devices"].items) {
      const std::string name = d["name"].str("");
      const std::string at = bus["name"].str("") + ":" + d["node_id"].str("");
      bus_of = &bus;
      if (name == wanted || at == wanted) return &d;
      known += (known.empty() ? "" : ", ") + name;
    }
  }
  return nullptr;
}

// Whether the capture an event names is still on disk: the bus keeps
// capture_cap_mib of captures and deletes the oldest, so an old event's
// frames may be gone; a capture still being written is not there yet.
struct CapturesOnDisk {
  std::vector<std::string> names;
  bool pending = false;

  explicit CapturesOnDisk(const Json& bus) {
    const Json& rec = bus["recorder"];
    if (rec.is_null()) return;
    for (const auto& c : rec["captures"].items) names.push_back(c["name"].str(""));
    pending = rec["pending_captures"].integer() > 0;
  }
  [[nodiscard]] bool has(const std::string& name) const {
    return std::find(names.begin(), names.end(), name) != names.end();
  }
  // What to say of a capture that is not on disk.
  [[nodiscard]] const char* missing() const {
    return pending ? " (not on disk: still being written, or deleted beyond capture_cap_mib)"
                   : " (no longer on disk: deleted beyond capture_cap_mib)";
  }
};

// "2026-11-28T04:30:01.123Z" -> "04:30:01.123"
std::string clock_of(const Json& t) {
  const std::string s = t.str("");
  return s.size() >= 23 ? s.substr(11, 12) : s;
}

void print_event(const Json& e, const CapturesOnDisk& disk) {
  const std::string kind = e["kind"].str("");
  std::string line = clock_of(e["at"]) + "  " + kind + std::string(12 - std::min<std::size_t>(11, kind.size()), ' ') +
                     e["text"].str("");
  if (e["repeats"].integer() > 1)
    line += " (x" + std::to_string(e["repeats"].integer()) + ", last " + clock_of(e["last_at"]) + ")";
  if (!e["capture"].is_null()) {
    const std::string name = e["capture"].str("");
    line += "\n" + std::string(26, ' ') + "frames: " + name + (disk.has(name) ? "" : disk.missing());
  }
  std::printf("%s\n", line.c_str());
}

void print_chain(const Json& d, std::size_t first, const CapturesOnDisk& disk) {
  std::printf("%s (bus %s, node %s): %s since %s%s%s\n", d["name"].str().c_str(), d["bus"].str().c_str(),
              d["node_id"].str().c_str(), d["state"].str().c_str(), d["since"].str().c_str(),
              d["last_error"].str("").empty() ? "" : ": ", d["last_error"].str("").c_str());
  const auto& events = d["timeline"].items;
  if (first >= events.size()) {
    std::printf("no events recorded\n");
    return;
  }
  bool captures = false;
  std::string day;  // events kept over a restart may span days: a line per day, as journalctl does
  for (std::size_t i = first; i < events.size(); ++i) {
    const std::string at = events[i]["at"].str("");
    if (at.substr(0, 10) != day) {
      day = at.substr(0, 10);
      std::printf("-- %s --\n", day.c_str());
    }
    print_event(events[i], disk);
    captures = captures || disk.has(events[i]["capture"].str(""));
  }
  if (captures) std::printf("`cobridge capture get NAME` prints a capture's frames (candump -l; canplayer replays it)\n");
}

void print_json(const Json& d, std::size_t first, const CapturesOnDisk& disk) {
  JsonWriter w;
  w.begin_object().field("device", d["name"].str("")).field("state", d["state"].str(""));
  w.field("since", d["since"].str("")).key("chain").begin_array();
  const auto& events = d["timeline"].items;
  for (std::size_t i = first; i < events.size(); ++i) {
    const Json& e = events[i];
    w.begin_object().field("at", e["at"].str("")).field("kind", e["kind"].str("")).field("text", e["text"].str(""));
    w.field("repeats", e["repeats"].integer());
    if (e["capture"].is_null()) {
      w.key("capture").null().key("capture_on_disk").null();
    } else {
      w.field("capture", e["capture"].str("")).field("capture_on_disk", disk.has(e["capture"].str("")));
    }
    w.end_object();
  }
  std::printf("%s\n", w.end_array().end_object().text().c_str());
}

}  // namespace

std::size_t chain_start(const Json& timeline, std::string_view state) {
  const auto& events = timeline.items;
  // The latest entries into operational, newest first.
  std::optional<std::size_t> last;
  std::optional<std::size_t> before_last;
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (!enters(events[i], "operational")) continue;
    before_last = last;
    last = i;
  }
  const std::optional<std::size_t> since = state == "operational" ? before_last : last;
  return since ? *since + 1 : 0;
}

int why(const WhyOptions& o) {
  int code = 0;
  const auto doc = ask_daemon(o.control, "status", "why", o.timeout_ms, false, code);
  if (!doc) return code;
  std::string known;
  const Json* bus = nullptr;
  const Json* d = find_device(*doc, o.device, known, bus);
  if (d == nullptr) {
    return report_failure("why", Error(Errc::kNotFound, "no such device (known: " + (known.empty() ? "none" : known) + ")",
                                       o.device), o.json);
  }
  const std::size_t first = o.all ? 0 : chain_start((*d)["timeline"], (*d)["state"].str(""));
  const CapturesOnDisk disk(*bus);
  if (o.json) {
    print_json(*d, first, disk);
  } else {
    print_chain(*d, first, disk);
  }
  return 0;
}

}  // namespace cobridge::cli
