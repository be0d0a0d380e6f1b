// [[device]]: one encoder each: identity, model or EDS, node-ID, preset.
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

#include "base/number_text.hpp"
#include "families/family_traits.hpp"

namespace cobridge::config::detail {

void Loader::read_device(const toml::table& t) {
  Device d;
  DeviceSpots spots;
  d.where = location(sink_, t);
  const toml::node* name_node = t.get("name");
  TableReader r(t, "[[device]]", entry_context("device", config_.devices.size() + 1, name_node), "", sink_);
  r.check_keys({"name", "bus", "serial", "vendor", "product", "node_id", "model", "channels", "eds", "tpdo1", "tpdo2",
                "heartbeat_ms", "guarding", "direction", "scaling", "preset", "cam", "work_area", "position_filter",
                "speed_filter", "store", "on_config_drift"});
  read_name(r, name_node, d.name, spots.name, spots.has_name);
  read_address(r, d, spots);
  const KnownModel* model = read_model(r, d);
  read_communication(r, d);
  read_functions(r, d, model);
  config_.devices.push_back(std::move(d));
  device_spots_.push_back(spots);
}

// Where the device is: its bus, serial (the LSS address with vendor and
// product) and node-ID.
void Loader::read_address(TableReader& r, Device& d, DeviceSpots& spots) {
  if (auto v = r.string("bus")) {
    d.bus = *v;
    spots.bus = location(sink_, *r.find("bus"));
    spots.has_bus = true;
  } else if (r.find("bus") == nullptr) {
    r.missing("bus");
  }
  if (auto v = r.integer("serial", 0, kU32)) {
    d.serial = static_cast<std::uint32_t>(*v);
    spots.serial = location(sink_, *r.find("serial"));
    spots.has_serial = true;
  } else if (r.find("serial") == nullptr) {
    r.missing("serial");
  }
  if (auto v = r.integer("vendor", 0, kU32)) d.vendor = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("product", 0, kU32)) d.product = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("node_id", 1, 127)) {
    d.node_id = static_cast<std::uint8_t>(*v);
    spots.node_id = location(sink_, *r.find("node_id"));
  }
}

// What the device is: a known model or an EDS file, and its channels; the
// model found, or nullptr.
const KnownModel* Loader::read_model(TableReader& r, Device& d) {
  const KnownModel* model = nullptr;
  if (auto v = r.string("model")) {
    model = find_model(*v);
    if (model != nullptr) {
      d.model = *v;
    } else {
      std::string names;
      for (const auto& m : known_models()) {
        if (!names.empty()) names += ", ";
        names += m.name;
      }
      r.error(*r.find("model"), "model " + in_quotes(*v) + " is not known (allowed: " + names + "; or give eds = \"path\")");
    }
  }
  if (auto v = r.string("eds")) {
    if (r.find("model") != nullptr) {
      r.error(*r.find("eds"), "give either model or eds, not both");
    } else {
      check_eds(r, d, *v);
    }
  }
  if (model != nullptr) check_identity(r, d, *model);
  if (auto v = r.integer("channels", 1, 2)) {
    if (model == nullptr || model->max_channels < 2) {
      r.error(*r.find("channels"), "channels is only allowed with a model of the rotary series (RFC-4800, RSA-3200, "
                                   "RFE-3200, RSX-7900, RFX-6900)");
    } else {
      d.channels = static_cast<std::uint8_t>(*v);
    }
  }
  return model;
}

// TPDOs and the error control the device produces.
void Loader::read_communication(TableReader& r, Device& d) {
  d.tpdo1 = read_tpdo(r, "tpdo1");
  d.tpdo2 = read_tpdo(r, "tpdo2");
  if (auto v = r.integer("heartbeat_ms", 0, kU16)) d.heartbeat_ms = static_cast<std::uint16_t>(*v);
  d.guarding = read_guarding(r);
  if (r.find("heartbeat_ms") != nullptr && r.find("guarding") != nullptr) {
    // CiA 301 §7.2.8.3.2: a node produces heartbeats or answers node
    // guarding, not both; configuring both would leave it to the device.
    r.error(*r.find("guarding"), "give either heartbeat_ms or [device.guarding], not both");
  }
}

// The encoder's own functions: direction, scaling, preset, CAMs, work area,
// filters, and when to store.
void Loader::read_functions(TableReader& r, Device& d, const KnownModel* model) {
  d.direction = r.choice<Direction>("direction", {{"cw", Direction::cw}, {"ccw", Direction::ccw}});
  d.scaling = read_scaling(r);
  read_preset(r, d, model);
  std::int64_t max_cam = 8;
  if (model != nullptr) {
    const std::uint8_t channels = d.channels.value_or(model->max_channels);
    max_cam = static_cast<std::int64_t>(model->cams_per_channel) * channels;
  }
  read_cams(r, d, max_cam);
  d.work_area = read_work_area(r);
  if (auto v = r.integer("position_filter", 0, 7)) {
    if (model != nullptr && !model->position_filter) {
      r.error(*r.find("position_filter"), "position_filter is not supported by model " + in_quotes(model->name));
    } else {
      d.position_filter = static_cast<std::uint8_t>(*v);
    }
  }
  if (auto v = r.integer("speed_filter", 0, 8)) {
    if (model != nullptr && !model->speed_filter) {
      r.error(*r.find("speed_filter"), "speed_filter is not supported by model " + in_quotes(model->name) +
                                           " (only by the multiturn series MZ1-2200, MC1-2800, MB1-3600)");
    } else {
      d.speed_filter = static_cast<std::uint8_t>(*v);
    }
  }
  if (auto v = r.choice<StorePolicy>(
          "store", {{"on-change", StorePolicy::on_change}, {"always", StorePolicy::always}, {"never", StorePolicy::never}})) {
    d.store = *v;
  }
  if (auto v = r.choice<DriftPolicy>("on_config_drift",
                                     {{"restore", DriftPolicy::restore}, {"keep", DriftPolicy::keep}})) {
    d.on_config_drift = *v;
  }
}

void Loader::check_eds(TableReader& r, Device& d, const std::string& value) {
  const toml::node& n = *r.find("eds");
  if (value.empty()) {
    r.error(n, "eds must name a file, got \"\"");
    return;
  }
  const fs::path path = resolve(value);
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    r.error(n, "eds file " + in_quotes(path.string()) + " does not exist");
  } else if (!fs::is_regular_file(status)) {
    r.error(n, "eds file " + in_quotes(path.string()) + " is not a regular file");
  } else if (::access(path.c_str(), R_OK) != 0) {
    r.error(n, "eds file " + in_quotes(path.string()) + " is not readable: " + std::strerror(errno));
  } else {
    d.eds = path;
  }
}

void Loader::check_identity(TableReader& r, const Device& d, const KnownModel& model) {
  if (d.vendor && *d.vendor != model.vendor) {
    r.error(*r.find("vendor"), "vendor " + hex(*d.vendor, 8) + " does not match model " + in_quotes(model.name) +
                                   " (vendor " + hex(model.vendor, 8) + ")");
  }
  if (d.product && !model.products.empty() &&
      std::find(model.products.begin(), model.products.end(), *d.product) == model.products.end()) {
    std::string codes;
    for (const auto p : model.products) {
      if (!codes.empty()) codes += ", ";
      codes += hex(p, 8);
    }
    r.error(*r.find("product"), "product " + hex(*d.product, 8) + " does not match model " + in_quotes(model.name) +
                                    " (allowed: " + codes + ")");
  }
}

void Loader::read_preset(TableReader& r, Device& d, const KnownModel* model) {
  // INTEGER32 on the rotary series (J 0x6010), UNSIGNED32 on the others
  // (E, F 0x6003); unknown models get the union.
  std::int64_t min = kI32Min;
  std::int64_t max = kU32;
  if (model != nullptr) {
    if (families::traits(model->family).preset_signed) {
      max = kI32Max;
    } else {
      min = 0;
    }
  }
  if (auto v = r.integer("preset", min, max)) d.preset = *v;
}

}  // namespace cobridge::config::detail
