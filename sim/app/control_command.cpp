#include "app/control_command.hpp"

#include "app/number_text.hpp"

#include <array>
#include <vector>

namespace cobridge::sim {

namespace {

constexpr std::array<FaultKind, 10> kFaultKinds{
    FaultKind::measurement_error, FaultKind::over_range,        FaultKind::under_range,
    FaultKind::hardware_fault,    FaultKind::temperature_high,  FaultKind::temperature_low,
    FaultKind::voltage_high,      FaultKind::voltage_low,       FaultKind::channel_disagreement,
    FaultKind::clear};

// Longest flood/babble/etc. a single command may ask for: one hour.
constexpr std::uint64_t kMaxDurationMs = 3'600'000;

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

ControlParse fail(std::string message) { return ControlParse{std::nullopt, std::move(message)}; }

}  // namespace

std::optional<FaultKind> parse_fault_kind(std::string_view text) noexcept {
  for (const FaultKind k : kFaultKinds)
    if (text == to_string(k)) return k;
  return std::nullopt;
}

std::string_view to_string(FaultKind kind) noexcept {
  switch (kind) {
    case FaultKind::measurement_error: return "measurement-error";
    case FaultKind::over_range: return "over-range";
    case FaultKind::under_range: return "under-range";
    case FaultKind::hardware_fault: return "hardware-fault";
    case FaultKind::temperature_high: return "temperature-high";
    case FaultKind::temperature_low: return "temperature-low";
    case FaultKind::voltage_high: return "voltage-high";
    case FaultKind::voltage_low: return "voltage-low";
    case FaultKind::channel_disagreement: return "channel-disagreement";
    case FaultKind::clear: return "clear";
  }
  return "?";
}

std::string fault_kind_names() {
  std::string out;
  for (const FaultKind k : kFaultKinds) {
    if (!out.empty()) out += '|';
    out += to_string(k);
  }
  return out;
}

std::string_view control_help() noexcept {
  return "Control commands (stdin and --control socket; one reply line each, 'ok ...' or 'error ...'):\n"
         "  list                              devices: serial:model:iface:node:state\n"
         "  power-cycle <serial>              power off, then on (boot-up, non-volatile memory reloaded)\n"
         "  power-off <serial>                silent until power-on; RAM lost\n"
         "  power-on <serial>\n"
         "  silence <serial> on|off           cable pulled: no RX, no TX, state kept\n"
         "  reboot-on-sdo <serial> <n>        power-cycle when the n-th SDO request from now arrives\n"
         "                                    (that request is never answered; 0 cancels)\n"
         "  abort-sdo <serial> <index hex> [code hex]  answer the next SDO request for that object\n"
         "                                    with an abort (default code 08000020; index 0 cancels)\n"
         "  ignore-sdo <serial> <index hex> <n>  leave the next n SDO requests for that object\n"
         "                                    unanswered (an SDO timeout; 0 cancels)\n"
         "  fault <serial> <kind>             measurement-error|over-range|under-range|hardware-fault|\n"
         "                                    temperature-high|temperature-low|voltage-high|voltage-low|\n"
         "                                    channel-disagreement|clear\n"
         "  move <serial> <turns>             shift the shaft by <turns> (offset; e.g. -0.25)\n"
         "  flood <iface> <ms>                identifier 0x000 (DLC 0) back to back; the simulated\n"
         "                                    devices on that bus lose arbitration and send nothing\n"
         "  babble <iface> <cob-id hex> <ms>  one identifier back to back, 8 changing data bytes\n"
         "  bus-error <iface> <kind>          send a Linux CAN error frame: error-warning|error-passive|\n"
         "                                    error-active|bus-off|restarted\n"
         "  stats                             loop timing and bus counters\n"
         "  help                              this text (one line)\n"
         "  quit                              end cobridge-sim\n";
}

namespace {

// One command line being parsed: its words and the command they build.
struct CommandWords {
  std::vector<std::string_view> w;
  ControlCommand c;

  [[nodiscard]] std::optional<ControlParse> want_args(std::size_t n, std::string_view usage) const {
    if (w.size() != n + 1) return fail("usage: " + std::string(usage));
    return std::nullopt;
  }
  bool serial_at(std::size_t i) {
    const auto v = parse_unsigned(w[i], UINT32_MAX);
    if (!v) return false;
    c.serial = static_cast<std::uint32_t>(*v);
    return true;
  }
  bool duration_at(std::size_t i) {
    const auto v = parse_unsigned(w[i], kMaxDurationMs);
    if (!v || *v == 0) return false;
    c.duration_ms = static_cast<std::uint32_t>(*v);
    return true;
  }
  [[nodiscard]] ControlParse bad_serial() const {
    return fail("serial must be a number (decimal or 0x hex), got '" + std::string(w[1]) + "'");
  }
  [[nodiscard]] ControlParse done() const { return ControlParse{c, {}}; }
};

// Commands on one simulated device: `<verb> <serial> ...`.
std::optional<ControlParse> parse_device_command(CommandWords& p, std::string_view verb) {
  if (verb == "power-cycle" || verb == "power-off" || verb == "power-on") {
    if (auto e = p.want_args(1, std::string(verb) + " <serial>")) return *e;
    if (!p.serial_at(1)) return p.bad_serial();
    p.c.verb = verb == "power-cycle" ? ControlVerb::power_cycle
               : verb == "power-off" ? ControlVerb::power_off
                                     : ControlVerb::power_on;
    return p.done();
  }
  if (verb == "silence") {
    if (auto e = p.want_args(2, "silence <serial> on|off")) return *e;
    if (!p.serial_at(1)) return p.bad_serial();
    if (p.w[2] != "on" && p.w[2] != "off") return fail("silence wants on|off, got '" + std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::silence;
    p.c.on = p.w[2] == "on";
    return p.done();
  }
  if (verb == "reboot-on-sdo") {
    if (auto e = p.want_args(2, "reboot-on-sdo <serial> <n>")) return *e;
    if (!p.serial_at(1)) return p.bad_serial();
    const auto n = parse_unsigned(p.w[2], 1000000);
    if (!n) return fail("n must be 0..1000000, got '" + std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::reboot_on_sdo;
    p.c.count = static_cast<std::uint32_t>(*n);
    return p.done();
  }
  if (verb == "fault") {
    if (auto e = p.want_args(2, "fault <serial> <kind>")) return *e;
    if (!p.serial_at(1)) return p.bad_serial();
    const auto k = parse_fault_kind(p.w[2]);
    if (!k) return fail("fault kind must be " + fault_kind_names() + ", got '" + std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::fault;
    p.c.fault = *k;
    return p.done();
  }
  if (verb == "move") {
    if (auto e = p.want_args(2, "move <serial> <turns>")) return *e;
    if (!p.serial_at(1)) return p.bad_serial();
    const auto t = parse_real(p.w[2]);
    if (!t) return fail("turns must be a decimal number such as 0.25 or -3, got '" + std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::move;
    p.c.turns = *t;
    return p.done();
  }
  return std::nullopt;
}

// `abort-sdo <serial> <index hex> [code hex]`: a device refusing one SDO
// transfer (CiA 301 §7.2.4.3.17); `ignore-sdo <serial> <index hex> <n>`: a
// device not answering n requests. Configuration faults for the daemon.
std::optional<ControlParse> parse_sdo_fault_command(CommandWords& p, std::string_view verb) {
  if (verb != "abort-sdo" && verb != "ignore-sdo") return std::nullopt;
  const bool ignore = verb == "ignore-sdo";
  if (ignore ? p.w.size() != 4 : (p.w.size() != 3 && p.w.size() != 4))
    return fail(ignore ? "usage: ignore-sdo <serial> <index hex> <n>" : "usage: abort-sdo <serial> <index hex> [code hex]");
  if (!p.serial_at(1)) return p.bad_serial();
  const auto index = parse_hex32(p.w[2]);
  if (!index || *index > 0xFFFF) return fail("index must be hex 0..FFFF, got '" + std::string(p.w[2]) + "'");
  p.c.sdo_index = static_cast<std::uint16_t>(*index);
  if (ignore) {
    const auto n = parse_unsigned(p.w[3], 1000);
    if (!n) return fail("n must be 0..1000, got '" + std::string(p.w[3]) + "'");
    p.c.verb = ControlVerb::ignore_sdo;
    p.c.count = static_cast<std::uint32_t>(*n);
    return p.done();
  }
  const auto code = p.w.size() == 4 ? parse_hex32(p.w[3]) : std::optional<std::uint32_t>(0x08000020u);
  if (!code || *code == 0) return fail("code must be a non-zero hex abort code, got '" + std::string(p.w[3]) + "'");
  p.c.verb = ControlVerb::abort_sdo;
  p.c.abort_code = *code;
  return p.done();
}

// Commands on one bus: `<verb> <iface> ...`.
std::optional<ControlParse> parse_bus_command(CommandWords& p, std::string_view verb) {
  if (verb == "flood") {
    if (auto e = p.want_args(2, "flood <iface> <ms>")) return *e;
    p.c.iface = std::string(p.w[1]);
    if (!p.duration_at(2)) return fail("ms must be 1..3600000, got '" + std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::flood;
    return p.done();
  }
  if (verb == "babble") {
    if (auto e = p.want_args(3, "babble <iface> <cob-id hex> <ms>")) return *e;
    p.c.iface = std::string(p.w[1]);
    const auto id = parse_hex32(p.w[2]);
    if (!id || *id > 0x1FFFFFFF) return fail("cob-id must be hex 0..7FF (or 29-bit), got '" + std::string(p.w[2]) + "'");
    p.c.cob_id = *id;
    if (!p.duration_at(3)) return fail("ms must be 1..3600000, got '" + std::string(p.w[3]) + "'");
    p.c.verb = ControlVerb::babble;
    return p.done();
  }
  if (verb == "bus-error") {
    if (auto e = p.want_args(2, "bus-error <iface> error-warning|error-passive|error-active|bus-off|restarted")) return *e;
    p.c.iface = std::string(p.w[1]);
    const auto k = parse_bus_error_kind(p.w[2]);
    if (!k)
      return fail("bus-error kind must be error-warning|error-passive|error-active|bus-off|restarted, got '" +
                  std::string(p.w[2]) + "'");
    p.c.verb = ControlVerb::bus_error;
    p.c.bus_error = *k;
    return p.done();
  }
  return std::nullopt;
}

}  // namespace

ControlParse parse_control_command(std::string_view line) {
  CommandWords p{split_words(line), {}};
  if (p.w.empty()) return fail("empty command (try 'help')");
  const std::string_view verb = p.w[0];
  if (verb == "list" || verb == "stats" || verb == "help" || verb == "quit") {
    if (auto e = p.want_args(0, verb)) return *e;
    p.c.verb = verb == "list" ? ControlVerb::list
               : verb == "stats" ? ControlVerb::stats
               : verb == "help" ? ControlVerb::help
                                : ControlVerb::quit;
    return p.done();
  }
  if (auto r = parse_device_command(p, verb)) return *r;
  if (auto r = parse_sdo_fault_command(p, verb)) return *r;
  if (auto r = parse_bus_command(p, verb)) return *r;
  return fail("unknown command '" + std::string(verb) + "' (try 'help')");
}

}  // namespace cobridge::sim
