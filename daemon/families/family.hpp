// A device family: the facts of one manual that every part of cobridge needs
// (the daemon's configuration checks, discovery and plans, the EDS generator
// and checker, the simulator), defined once. One family per file pair in this
// folder (novotechnik_rotary, novotechnik_multiturn, ifm_rm); this header is
// their common shape and the registry that lists them. Facts that need the
// object dictionary's types (mapping entries, signals) are built from these in
// device/family_profile.
//
// Adding a family: docs/adding-a-device.md.
//
// Thread contract: constant tables; any thread, no allocation (but
// cite_manuals, which builds a string for people).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "families/emcy_table.hpp"

namespace cobridge::families {

// The one identity of a family, for code that branches on it (a switch
// without `default`, so that -Wswitch names every place a new family must be
// handled). Each Family names its own; `family(id)` gives the facts back and
// `traits(id)` (family_traits.hpp) the behaviour that differs by family. A device no family knows has none
// (a `const Family*` that is nullptr, or an empty optional).
enum class FamilyId : std::uint8_t { novotechnik_rotary, novotechnik_multiturn, ifm_rm };

// CiA 301 §7.5.2.13 object 0x1010: the 'save' signature, "save" read as an
// UNSIGNED32 (J§1.6.1, E§11, F§6.3.3).
inline constexpr std::uint32_t kSaveSignature = 0x65766173;
inline constexpr std::uint16_t kStoreObject = 0x1010;

// One orderable model of a family.
struct Model {
  std::string_view name;  // as a [[device]] model = "..." and cobridge-sim --device name it
  // Product codes (0x1018/2) the model may report, current firmware first;
  // empty = the manual prints none that can be checked (ifm, F§7.3).
  std::span<const std::uint32_t> products;
  std::uint8_t max_channels = 1;      // position channels
  std::uint8_t cams_per_channel = 4;  // CAMs 1..n per channel
  bool position_filter = false;       // moving average configurable
  bool speed_filter = false;          // separate speed filter
  bool legacy_rsx_rfx = false;        // J§1.12 V10: RSX-7900 / RFX-6900 firmware rules
  bool simulated = true;              // cobridge-sim offers it
  // The simulator's name for a device that reports products[1] (firmware
  // before a product-code change); empty when there is none.
  std::string_view legacy_product_name;
  std::string_view eds_stem;  // config/devices/<stem>[-1ch|-2ch].eds
};

// 0x1010 sub-index whose 'save' stores each group of parameters.
struct StoreSubs {
  std::uint8_t communication = 1;
  std::uint8_t application = 1;
  std::uint8_t node_id = 1;  // node-ID and bit rate
};

// How the node-ID and bit rate are set through SDO (where LSS is missing or
// undocumented, and in every configuration plan).
struct Addressing {
  std::uint16_t node_id_index = 0x2000;
  std::uint8_t node_id_offset = 0;  // value written = node-ID - offset
  std::uint16_t bitrate_index = 0x2001;
  bool bitrate_is_table_index = false;  // value = index into `bitrates`, not kbit/s
  std::span<const std::uint16_t> bitrates;  // kbit/s the family offers
};

struct Family {
  FamilyId id = FamilyId::novotechnik_rotary;
  std::string_view name;    // EDS [Cobridge] Family value, e.g. "novotechnik-rotary"
  std::string_view series;  // for messages: "rotary series"
  std::string_view manual;  // citation key: "J", "E", "F"
  std::string_view manual_title;  // how people name that manual, e.g. "Novotechnik rotary CANopen manual"
  std::uint32_t vendor = 0;  // 0x1018/1
  std::span<const Model> models;
  // Selected by vendor alone when no model lists the product (its product
  // code is not reliably documented), and the code the simulator reports.
  bool match_any_product = false;
  std::uint32_t simulated_product = 0;
  std::uint8_t factory_node_id = 127;
  std::uint16_t factory_bitrate_kbit = 250;
  // False: LSS before CiA 305 V2 (no Fastscan), separated by Slowscan.
  bool lss_fastscan = true;
  Addressing addressing;
  StoreSubs store;
  // Every object the manual's object tables name (the EDS check wants each
  // in the family's EDS files).
  std::span<const std::uint16_t> manual_objects;
  // 0x6000 bit 2 value that switches scaling on.
  bool scaling_on_bit_value = true;
  // What the manual says its EMCY codes mean; nullptr when it lists none.
  const EmcyTable* emcy = nullptr;

  [[nodiscard]] bool lists_product(std::uint32_t product) const noexcept;
  // The model that lists `product`; nullptr if none does.
  [[nodiscard]] const Model* model_of(std::uint32_t product) const noexcept;
};

// `text` with each citation key ("J§1.8.1") spelled out for people as the
// manual's title and section ("Novotechnik rotary CANopen manual §1.8.1").
[[nodiscard]] std::string cite_manuals(std::string_view text);

// Every family, in a fixed order (rotary, multiturn, ifm).
[[nodiscard]] std::span<const Family* const> all() noexcept;
// The family of an identity.
[[nodiscard]] const Family& family(FamilyId id) noexcept;
// By EDS [Cobridge] Family name; nullptr if unknown.
[[nodiscard]] const Family* find_family(std::string_view name) noexcept;
// The family of a device identity (0x1018/1, 0x1018/2); nullptr if none.
[[nodiscard]] const Family* family_of(std::uint32_t vendor, std::uint32_t product) noexcept;

struct ModelRef {
  const Family* family = nullptr;
  const Model* model = nullptr;
};
// By exact model name; {nullptr, nullptr} if unknown.
[[nodiscard]] ModelRef find_model(std::string_view name) noexcept;

}  // namespace cobridge::families
