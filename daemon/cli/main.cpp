// cobridge: the command-line tool. Wires CLI11 subcommands to the command
// modules; all work is in scan_command, sdo_command, nmt_command, lss_command,
// status_command.
#include "cli/acknowledge_command.hpp"
#include "cli/capture_command.hpp"
#include "cli/lss_command.hpp"
#include "cli/modbus_map_command.hpp"
#include "cli/nmt_command.hpp"
#include "cli/scan_command.hpp"
#include "cli/sdo_command.hpp"
#include "cli/status_command.hpp"
#include "cli/why_command.hpp"
#include "cli/watch_command.hpp"
#include "sys/logging.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <cstdio>

namespace {

using namespace cobridge::cli;

// Every subcommand's options and its CLI11 handle; main() runs the one given.
struct Commands {
  ScanOptions scan_o;
  SdoOptions sdo_o;
  NmtOptions nmt_o;
  LssSetNodeOptions lss_o;
  StatusOptions status_o;
  CommissionOptions commission_o;
  WatchOptions watch_o;
  ModbusMapOptions modbus_map_o;
  CaptureOptions capture_o;
  WhyOptions why_o;
  AcknowledgeOptions acknowledge_o;
  CLI::App* acknowledge_c = nullptr;
  CLI::App* why_c = nullptr;
  CLI::App* scan_c = nullptr;
  CLI::App* sdo_r = nullptr;
  CLI::App* sdo_w = nullptr;
  CLI::App* nmt_c = nullptr;
  CLI::App* lss_set = nullptr;
  CLI::App* status_c = nullptr;
  CLI::App* commission_c = nullptr;
  CLI::App* watch_c = nullptr;
  CLI::App* modbus_map_c = nullptr;
  CLI::App* capture_c = nullptr;
};

void add_scan(CLI::App& app, Commands& k) {
  auto& scan_o = k.scan_o;
  auto* scan_c = k.scan_c = app.add_subcommand("scan", "list the devices on a bus: boot-ups, SDO identity probe, LSS Fastscan");
  scan_c->add_option("-i,--iface", scan_o.iface, "CAN interface (e.g. can0, vcan0)")->required();
  scan_c->add_option("--listen-ms", scan_o.listen_ms, "how long to listen for boot-up/heartbeat")->capture_default_str();
  scan_c->add_option("--sdo-timeout-ms", scan_o.sdo_timeout_ms, "SDO answer window")->capture_default_str();
  scan_c->add_option("--lss-timeout-ms", scan_o.lss_timeout_ms, "the longest LSS answer window of a Fastscan step (shorter once answers were seen, as the daemon's)")->capture_default_str();
  scan_c->add_flag("!--no-fastscan", scan_o.fastscan, "skip LSS Fastscan");
  scan_c->add_option("--assign-from", scan_o.assign_from,
                     "give each non-configured device found by Fastscan the next free node-ID from N, and store it")
      ->check(CLI::Range(1, 127));
  scan_c->add_option("--devices-dir", scan_o.devices_dir, "EDS directory used to name models");
  scan_c->add_flag("--json", scan_o.json, "machine-readable output");
  scan_c->add_option("--control", scan_o.control, "daemon control socket (its view is shown when it owns the bus)")
      ->capture_default_str();
}

void add_sdo(CLI::App& app, Commands& k) {
  auto& sdo_o = k.sdo_o;
  auto* sdo_c = app.add_subcommand("sdo", "read or write one object of one node (CiA 301 SDO)");
  sdo_c->require_subcommand(1);
  auto* sdo_r = k.sdo_r = sdo_c->add_subcommand("read", "upload INDEX[:SUB]");
  auto* sdo_w = k.sdo_w = sdo_c->add_subcommand("write", "download VALUE to INDEX[:SUB]");
  for (auto* c : {sdo_r, sdo_w}) {
    c->add_option("-i,--iface", sdo_o.iface, "CAN interface")->required();
    c->add_option("-n,--node", sdo_o.node, "node-ID 1..127")->required();
    c->add_option("object", sdo_o.object, "object as hex INDEX[:SUB], e.g. 1018:4")->required();
    c->add_flag("--string", sdo_o.as_string, "treat the value as text");
    c->add_option("--timeout-ms", sdo_o.timeout_ms, "SDO timeout")->capture_default_str();
    c->add_flag("--json", sdo_o.json, "machine-readable output");
    c->add_option("--control", sdo_o.control, "daemon control socket (used when a daemon owns the bus)")
        ->capture_default_str();
  }
  sdo_w->add_option("value", sdo_o.value, "value: decimal, 0x-hex, or text with --string")->required();
  sdo_w->add_option("-s,--size", sdo_o.size, "bytes to write: 1, 2 or 4 (default 4)");
}

void add_nmt_and_lss(CLI::App& app, Commands& k) {
  auto& nmt_o = k.nmt_o;
  auto& lss_o = k.lss_o;
  auto* nmt_c = k.nmt_c = app.add_subcommand("nmt", "send an NMT command: start|stop|preop|reset|reset-comm NODE|all");
  nmt_c->add_option("-i,--iface", nmt_o.iface, "CAN interface")->required();
  nmt_c->add_option("command", nmt_o.command, "start, stop, preop, reset, reset-comm")->required();
  nmt_c->add_option("node", nmt_o.node, "1..127 or all")->required();
  nmt_c->add_flag("--json", nmt_o.json, "machine-readable output");
  nmt_c->add_option("--control", nmt_o.control, "daemon control socket (used when a daemon owns the bus)")
      ->capture_default_str();

  auto* lss_c = app.add_subcommand("lss", "layer setting services (CiA 305)");
  lss_c->require_subcommand(1);
  auto* lss_set = k.lss_set = lss_c->add_subcommand("set-node-id", "switch one device selectively by identity, set and store its node-ID");
  lss_set->add_option("-i,--iface", lss_o.iface, "CAN interface")->required();
  lss_set->add_option("--vendor", lss_o.vendor, "vendor-ID (0x1018/1)")->required();
  lss_set->add_option("--product", lss_o.product, "product code (0x1018/2)")->required();
  lss_set->add_option("--revision", lss_o.revision, "revision (0x1018/3)")->required();
  lss_set->add_option("--serial", lss_o.serial, "serial number (0x1018/4)")->required();
  lss_set->add_option("node", lss_o.node, "new node-ID 1..127")->required();
  lss_set->add_flag("!--no-store", lss_o.store, "do not store the node-ID in the device");
  lss_set->add_option("--timeout-ms", lss_o.timeout_ms, "LSS answer timeout")->capture_default_str();
  lss_set->add_flag("--json", lss_o.json, "machine-readable output");
  lss_set->add_option("--control", lss_o.control, "daemon control socket (used when a daemon owns the bus)")
      ->capture_default_str();
}

void add_daemon_commands(CLI::App& app, Commands& k) {
  auto& status_o = k.status_o;
  auto& commission_o = k.commission_o;
  auto* status_c = k.status_c = app.add_subcommand("status", "show the running daemon's buses, devices, step timings and counters");
  status_c->add_option("--control", status_o.control, "daemon control socket")->capture_default_str();
  status_c->add_flag("--json", status_o.json, "the daemon's JSON document, unchanged");

  auto* commission_c = k.commission_c =
      app.add_subcommand("commission", "ask the running daemon to commission its buses now (resolve clashes, assign node-IDs)");
  commission_c->add_option("--bus", commission_o.bus, "only this bus (a [[bus]] name of the daemon's configuration)");
  commission_c->add_option("--control", commission_o.control, "daemon control socket")->capture_default_str();
  commission_c->add_flag("--json", commission_o.json, "the daemon's JSON answer, unchanged");
}

void add_capture(CLI::App& app, Commands& k) {
  auto& o = k.capture_o;
  auto* c = k.capture_c = app.add_subcommand("capture", "the flight recorder's captures (candump logs around faults)");
  c->require_subcommand(1);
  auto* list = c->add_subcommand("list", "list the captures of every bus");
  list->callback([&o] { o.verb = CaptureOptions::Verb::list; });
  auto* now = c->add_subcommand("now", "capture the window around now (cause \"operator\")");
  now->add_option("bus", o.bus, "only this bus (name or interface)");
  now->callback([&o] { o.verb = CaptureOptions::Verb::now; });
  auto* get = c->add_subcommand("get", "print a capture file (candump -l format), or write it with -o");
  get->add_option("name", o.name, "the capture's name as `capture list` shows it")->required();
  get->add_option("-o,--output", o.output, "write to this file");
  get->callback([&o] { o.verb = CaptureOptions::Verb::get; });
  for (auto* s : {list, now, get}) {
    s->add_option("--control", o.control, "daemon control socket")->capture_default_str();
    s->add_flag("--json", o.json, "machine-readable output");
  }
}

void add_why(CLI::App& app, Commands& k) {
  auto& o = k.why_o;
  auto* c = k.why_c = app.add_subcommand("why", "the chain of events that led to a device's present state, with its captures");
  c->add_option("device", o.device, "a device name, or BUS:NODE")->required();
  c->add_flag("--all", o.all, "the whole timeline (at most 100 events), not only the chain");
  c->add_option("--control", o.control, "daemon control socket")->capture_default_str();
  c->add_flag("--json", o.json, "machine-readable output");
}

void add_acknowledge(CLI::App& app, Commands& k) {
  auto& o = k.acknowledge_o;
  auto* c = k.acknowledge_c = app.add_subcommand(
      "acknowledge", "let the daemon write a device's contested configuration again (after another writer kept changing it)");
  c->add_option("device", o.device, "the device's name")->required();
  c->add_option("--control", o.control, "daemon control socket")->capture_default_str();
  c->add_flag("--json", o.json, "the daemon's JSON answer, unchanged");
}

void add_output_commands(CLI::App& app, Commands& k) {
  auto& watch_o = k.watch_o;
  auto& modbus_map_o = k.modbus_map_o;
  auto* watch_c = k.watch_c = app.add_subcommand("watch", "subscribe to the gateway's DDS topics and print live values");
  watch_c->add_option("--domain", watch_o.domain, "DDS domain id")->capture_default_str();
  watch_c->add_option("--gateway", watch_o.gateway, "only this gateway id");
  watch_c->add_option("--topic-prefix", watch_o.topic_prefix, "the plugin's topic_prefix");
  watch_c->add_flag("--json", watch_o.json, "one JSON object per line");
  watch_c->add_flag("--reliable", watch_o.reliable,
                    "read samples reliably and keep all of them (needs sample_reliability = \"reliable\")");
  watch_c->add_option("--count", watch_o.count, "exit after N samples (any topic)");
  watch_c->add_option("--timeout", watch_o.timeout_s, "exit after S seconds (exit code 3 if --count was not reached)");

  auto* modbus_map_c = k.modbus_map_c = app.add_subcommand("modbus-map", "print the Modbus TCP register map (--csv for SCADA import)");
  modbus_map_c->add_flag("--csv", modbus_map_o.csv, "CSV: address,name,type,unit,scale,access,description");
  modbus_map_c->add_option("--devices", modbus_map_o.devices, "device slots to list (the plugin's max_devices)")
      ->capture_default_str();
  modbus_map_c->add_option("--buses", modbus_map_o.buses, "bus blocks to list (0..16)")->capture_default_str();
}

int run(const Commands& k) {
  if (*k.scan_c) return scan(k.scan_o);
  if (*k.sdo_r) return sdo_read(k.sdo_o);
  if (*k.sdo_w) return sdo_write(k.sdo_o);
  if (*k.nmt_c) return nmt_send(k.nmt_o);
  if (*k.lss_set) return lss_set_node_id(k.lss_o);
  if (*k.status_c) return status(k.status_o);
  if (*k.commission_c) return commission(k.commission_o);
  if (*k.watch_c) return watch(k.watch_o);
  if (*k.modbus_map_c) return modbus_map(k.modbus_map_o);
  if (*k.capture_c) return capture(k.capture_o);
  if (*k.why_c) return why(k.why_o);
  if (*k.acknowledge_c) return acknowledge(k.acknowledge_o);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cobridge: commission and inspect CANopen encoders on SocketCAN buses"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "show the library's log lines (channel open/close, ...)");
  Commands k;
  add_scan(app, k);
  add_sdo(app, k);
  add_nmt_and_lss(app, k);
  add_daemon_commands(app, k);
  add_output_commands(app, k);
  add_capture(app, k);
  add_why(app, k);
  add_acknowledge(app, k);
  CLI11_PARSE(app, argc, argv);
  // The commands print their own errors; the layers' log lines are for -v.
  // (setup_logging: loggers made later take this level too, not only those made so far.)
  cobridge::sys::setup_logging(cobridge::sys::LogTarget::console, verbose ? spdlog::level::debug : spdlog::level::off);
  return run(k);
}
