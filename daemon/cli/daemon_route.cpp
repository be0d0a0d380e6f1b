#include "cli/daemon_route.hpp"

#include "cli/control_client.hpp"
#include "sys/bus_beacon.hpp"

#include <cstdio>

namespace cobridge::cli {
namespace {

Errc kind_named(const std::string& text) {
  for (int k = 0; k <= static_cast<int>(Errc::kInternal); ++k) {
    if (name(static_cast<Errc>(k)) == text) return static_cast<Errc>(k);
  }
  return Errc::kFailed;
}

}  // namespace

Error error_of_answer(const Json& doc) {
  const Json& e = doc["error"];
  if (e.type == Json::Type::string) return Error(Errc::kFailed, e.text);  // an older daemon
  Error out(kind_named(e["code"].str("failed")), e["message"].str(""), e["where"].str(""));
  const Json& detail = e["detail"];
  if (!detail.is_null() && detail["category"].str("") == "sdo_abort" && !doc["abort_code"].is_null())
    out.message += " (abort code " + doc["abort_code"].str("?") + ")";
  return out;
}

std::string control_for(const std::string& control, const std::string& iface, bool& owned, Error& error) {
  const auto owner = sys::find_bus_owner(iface, 2000, error);
  owned = owner.has_value() || static_cast<bool>(error);
  return owner ? owner->control : control;
}

std::optional<std::pair<Error, DaemonAnswer>> via_daemon(const std::string& control, const std::string& iface,
                                                         const std::string& line, int timeout_ms) {
  Error error;
  bool owned = false;
  const std::string path = control_for(control, iface, owned, error);
  if (error) return std::pair{std::move(error), DaemonAnswer{}};
  bool no_daemon = false;
  const Result<std::string> answer = request(path, line, timeout_ms, &no_daemon);
  if (!answer.ok()) {
    if (no_daemon && !owned) return std::nullopt;
    error = answer.error();
    if (owned) error.message = "cobridged serves " + iface + " (its control socket " + path + "): " + error.message;
    error.where = path;
    return std::pair{std::move(error), DaemonAnswer{}};
  }
  DaemonAnswer a;
  a.line = *answer;
  auto doc = JsonParser(*answer).parse();
  if (!doc.ok() || doc->type != Json::Type::object)
    return std::pair{
        Error(Errc::kInternal, "the daemon's answer is not a JSON object: " + doc.error().message, path), a};
  a.doc = std::move(doc).value();
  if (a.doc["ok"].type == Json::Type::boolean && a.doc["ok"].boolean) return std::pair{Error{}, std::move(a)};
  Error e = error_of_answer(a.doc);
  // A daemon that serves other buses does not own this one.
  if (!owned && e.kind == Errc::kNotFound && e.where.empty() && e.message.find("serves no bus") != std::string::npos)
    return std::nullopt;
  return std::pair{std::move(e), std::move(a)};
}

int report_daemon_failure(const char* what, const std::pair<Error, DaemonAnswer>& routed, bool json) {
  if (json && !routed.second.line.empty()) {
    std::printf("%s\n", routed.second.line.c_str());  // the daemon's JSON, unchanged
    return exit_code(routed.first.kind);
  }
  return report_failure(what, routed.first, json);
}

int report_failure(const char* what, const Error& error, bool json) {
  if (json) {
    std::printf("{\"ok\":false,\"error\":%s}\n", error.to_json().c_str());
  } else {
    std::fprintf(stderr, "cobridge: %s: %s\n", what, error.to_string().c_str());
  }
  return exit_code(error.kind);
}

// The daemon's answer to `line` as JSON, or the failure's exit code.
std::optional<Json> ask_daemon(const std::string& control, const std::string& line, const char* what, int timeout_ms,
                               bool json, int& code) {
  const Result<std::string> reply = request(control, line, timeout_ms);
  if (!reply.ok()) {
    code = report_failure(what, reply.error(), json);
    return std::nullopt;
  }
  const std::string* answer = &reply.value();
  Result<Json> parsed = JsonParser(*answer).parse();
  if (!parsed.ok() || parsed.value().type != Json::Type::object) {
    code = report_failure(what, Error(Errc::kInternal, "the daemon's answer is not a JSON object: " +
                                                           (parsed.ok() ? std::string("another value")
                                                                        : parsed.error().message)), json);
    return std::nullopt;
  }
  std::optional<Json> doc(std::move(parsed.value()));
  if ((*doc)["ok"].type == Json::Type::boolean && !(*doc)["ok"].boolean) {
    const Error e = error_of_answer(*doc);
    if (json) {
      std::printf("%s\n", answer->c_str());
    } else {
      std::fprintf(stderr, "cobridge: %s: %s\n", what, e.to_string().c_str());
    }
    code = exit_code(e.kind);
    return std::nullopt;
  }
  if (json) std::printf("%s\n", answer->c_str());
  return doc;
}

}  // namespace cobridge::cli
