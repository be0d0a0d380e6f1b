#include "cli/capture_command.hpp"

#include "base/error.hpp"
#include "base/json_writer.hpp"
#include "cli/control_client.hpp"
#include "cli/daemon_route.hpp"
#include "cli/json_value.hpp"

#include <cstdio>
#include <fstream>
#include <optional>

namespace cobridge::cli {
namespace {

std::optional<Json> ask(const CaptureOptions& o, const std::string& line, const char* what, int& code) {
  return ask_daemon(o.control, line, what, o.timeout_ms, o.json, code);
}

std::string joined(const Json& list) {
  std::string out;
  for (const auto& item : list.items) out += (out.empty() ? "" : ",") + item.str("(bus)");
  return out.empty() ? "-" : out;
}

void write_capture(JsonWriter& w, const Json& bus, const Json& c) {
  w.begin_object().field("bus", bus["name"].str()).field("name", c["name"].str()).key("causes").begin_array();
  for (const auto& item : c["causes"].items) w.value(item.text);
  w.end_array().field("at", c["at"].str()).field("frames", c["frames"].integer()).field("bytes", c["bytes"].integer());
  w.end_object();
}

int list(const CaptureOptions& o) {
  int code = 0;
  CaptureOptions quiet = o;
  quiet.json = false;  // the answer is printed here, not as it came
  const auto doc = ask(quiet, "status", "capture list", code);
  if (!doc) return code;
  JsonWriter w;
  w.begin_array();
  if (!o.json) std::printf("%-10s %-48s %-24s %-26s %8s %10s\n", "BUS", "NAME", "CAUSES", "AT", "FRAMES", "BYTES");
  for (const auto& bus : (*doc)["buses"].items) {
    const Json& rec = bus["recorder"];
    if (rec.is_null()) continue;
    for (const auto& c : rec["captures"].items) {
      if (o.json) {
        write_capture(w, bus, c);
      } else {
        std::printf("%-10s %-48s %-24s %-26s %8lld %10lld\n", bus["name"].str().c_str(), c["name"].str().c_str(),
                    joined(c["causes"]).c_str(), c["at"].str().c_str(), c["frames"].integer(), c["bytes"].integer());
      }
    }
  }
  if (o.json) std::printf("%s\n", w.end_array().text().c_str());
  return 0;
}

int get(const CaptureOptions& o) {
  int code = 0;
  CaptureOptions quiet = o;
  quiet.json = false;  // the answer is printed here, not as it came
  const auto doc = ask(quiet, "capture-get " + o.name, "capture get", code);
  if (!doc) return code;
  const std::string& text = (*doc)["text"].text;
  if (o.output.empty()) {
    std::fwrite(text.data(), 1, text.size(), stdout);
    return 0;
  }
  std::ofstream out(o.output, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) return report_failure("capture get", Error(Errc::kFailed, "cannot write", o.output), false);
  return 0;
}

}  // namespace

int capture(const CaptureOptions& o) {
  switch (o.verb) {
    case CaptureOptions::Verb::list:
      return list(o);
    case CaptureOptions::Verb::get:
      return get(o);
    case CaptureOptions::Verb::now:
      break;
  }
  int code = 0;
  const auto doc = ask(o, o.bus.empty() ? "capture-now" : "capture-now " + o.bus, "capture now", code);
  if (!doc) return code;
  if (!o.json) std::printf("capture requested on %s; %s\n", joined((*doc)["buses"]).c_str(), (*doc)["message"].str("").c_str());
  return 0;
}

}  // namespace cobridge::cli
