#include "cli/capture_command.hpp"

#include "base/error.hpp"
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

std::string json_list(const Json& list) {
  std::string out = "[";
  for (const auto& item : list.items) out += (out.size() > 1 ? "," : "") + json_quote(item.text);
  return out + "]";
}

int list(const CaptureOptions& o) {
  int code = 0;
  CaptureOptions quiet = o;
  quiet.json = false;  // the answer is printed here, not as it came
  const auto doc = ask(quiet, "status", "capture list", code);
  if (!doc) return code;
  if (o.json) std::printf("[");
  bool first = true;
  if (!o.json) std::printf("%-10s %-48s %-24s %-26s %8s %10s\n", "BUS", "NAME", "CAUSES", "AT", "FRAMES", "BYTES");
  for (const auto& bus : (*doc)["buses"].items) {
    const Json& rec = bus["recorder"];
    if (rec.is_null()) continue;
    for (const auto& c : rec["captures"].items) {
      if (o.json) {
        std::printf("%s{\"bus\":%s,\"name\":%s,\"causes\":%s,\"at\":%s,\"frames\":%lld,\"bytes\":%lld}",
                    first ? "" : ",", json_quote(bus["name"].str()).c_str(), json_quote(c["name"].str()).c_str(),
                    json_list(c["causes"]).c_str(), json_quote(c["at"].str()).c_str(), c["frames"].integer(),
                    c["bytes"].integer());
      } else {
        std::printf("%-10s %-48s %-24s %-26s %8lld %10lld\n", bus["name"].str().c_str(), c["name"].str().c_str(),
                    joined(c["causes"]).c_str(), c["at"].str().c_str(), c["frames"].integer(), c["bytes"].integer());
      }
      first = false;
    }
  }
  if (o.json) std::printf("]\n");
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
