// What the gateway knows of the devices a Fastscan may find at node-ID FFh,
// turned into a canopen::FastscanPlan.
//
// Known identities are confirmed whole instead of searched bit by bit:
//  * devices commissioning itself took off their node-ID: whole identities;
//  * configured devices not present at a node-ID: vendor (configured, else
//    the model's, else its EDS file's), product (configured, else each
//    product code of the model),
//    serial (configured), revision when the remembered table has one for
//    that serial, else guessed from the revisions of the same vendor and
//    product found in this round or remembered (devices of one delivery
//    share their firmware), and searched when no guess is answered;
//  * configured models a new device may be (a same-model replacement, or a
//    device the `assign` policy places): vendor and product, the revisions
//    remembered for that product guessed, serial searched;
//  * `general`: whatever no target names is searched too (strangers).
// The ifm model lists no product code (F§7.3 prints an ambiguous one): its
// product is searched unless configured or remembered.
//
// Thread: pure function; called on the bus's control thread.
#pragma once

#include <span>
#include <vector>

#include "canopen/fastscan_plan.hpp"
#include "canopen/lss.hpp"
#include "config/config.hpp"
#include "bus/state_store.hpp"

namespace cobridge::bus {

struct FastscanKnowledge {
  std::vector<canopen::LssAddress> known;       // whole identities, tried first
  std::vector<const config::Device*> absent;    // configured devices not at a node-ID
  std::vector<const config::Device*> models;    // configured devices whose model a new device may be
  std::span<const Assignment> remembered;       // revisions (and products) seen before
  std::span<const canopen::LssAddress> found;   // identities found in this round so far
  // serial -> the VendorNumber of the device's EDS file (no vendor configured, no model)
  std::span<const std::pair<std::uint32_t, std::uint32_t>> eds_vendors;
  bool general = false;                         // also search what no target names
};

[[nodiscard]] canopen::FastscanPlan make_fastscan_plan(const FastscanKnowledge& k);

}  // namespace cobridge::bus
