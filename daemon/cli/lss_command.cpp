#include "cli/lss_command.hpp"

#include "base/json_writer.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/lss_master.hpp"
#include "cli/bus_session.hpp"
#include "cli/daemon_route.hpp"

#include <cstdio>

namespace cobridge::cli {
namespace {

// Runs one started LSS operation to its result.
std::optional<canopen::LssMaster::Result> await(BusSession& bus, canopen::LssMaster& m) {
  std::optional<canopen::LssMaster::Result> r;
  bus.run([&](const can::Frame& f, TimePoint now) { m.on_frame(f, now); },
          [&](TimePoint now) {
            const TimePoint next = m.process(now);
            if (!r) r = m.take_result();
            return next;
          },
          [&] { return r.has_value(); }, std::chrono::seconds(60));
  return r;
}

bool step(const char* what, BusSession& bus, canopen::LssMaster& m, std::error_code start_ec) {
  if (start_ec) {
    std::fprintf(stderr, "cobridge: lss: %s: %s\n", what, start_ec.message().c_str());
    return false;
  }
  auto r = await(bus, m);
  if (!r || r->error) {
    std::fprintf(stderr, "cobridge: lss: %s: %s\n", what, r ? r->error.message().c_str() : "no result");
    return false;
  }
  return true;
}

}  // namespace

int lss_set_node_id(const LssSetNodeOptions& o) {
  if (!canopen::cob::valid_node_id(o.node))
    return report_failure("lss", Error(Errc::kInvalidArgument, "--node " + std::to_string(o.node) + " (allowed: 1..127)"),
                          o.json);
  const std::string line = "lss-set-node-id " + o.iface + " " + std::to_string(o.vendor) + " " +
                           std::to_string(o.product) + " " + std::to_string(o.revision) + " " +
                           std::to_string(o.serial) + " " + std::to_string(o.node) + " " +
                           (o.store ? "store" : "no-store") + " " + std::to_string(o.timeout_ms);
  bool ok = true;
  if (auto routed = via_daemon(o.control, o.iface, line, 10000 + static_cast<int>(o.timeout_ms) * 8 + 5000)) {
    if (routed->first) return report_daemon_failure("lss", *routed, o.json);
  } else {
    auto opened = BusSession::open(o.iface);
    if (!opened.ok()) return report_failure("lss", opened.error(), o.json);
    const std::unique_ptr<BusSession> bus = std::move(opened).value();
    canopen::LssMaster m(bus->channel(), canopen::LssMaster::Config{.timeout = std::chrono::milliseconds(o.timeout_ms)});
    const canopen::LssAddress a{o.vendor, o.product, o.revision, o.serial};
    const auto now = [] { return canopen::Clock::now(); };
    ok = step("switch state selective", *bus, m, m.switch_state_selective(a, now())) &&
         step("configure node-ID", *bus, m, m.configure_node_id(static_cast<uint8_t>(o.node), now())) &&
         (!o.store || step("store configuration", *bus, m, m.store_configuration(now())));
    // Always leave configuration state, also after a failure, so the device is
    // not left listening to configuration commands.
    (void)m.switch_state_global(canopen::LssMode::kWaiting);
  }
  if (!ok) return exit_code(Errc::kFailed);
  if (o.json) {
    JsonWriter w;
    w.begin_object().field("ok", true).field("bus", o.iface).field("serial", o.serial).field("node", o.node);
    std::printf("%s\n", w.field("stored", o.store).end_object().text().c_str());
  } else {
    std::printf("serial %u: node-ID %u%s (active after the device's next reset)\n", o.serial, o.node,
                o.store ? ", stored" : "");
  }
  return 0;
}

}  // namespace cobridge::cli
