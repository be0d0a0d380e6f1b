// DescriptionChoice: which loaded device description (EDS) and family
// profile a device of the bus is configured and decoded with.
//
// Two moments choose one:
//   * a device identified at its node-ID (0x1018, CiA 301 §7.5.2.35):
//     the EDS file the configuration names, else the catalog's selection by
//     vendor, product and revision (and the channel variant the
//     configuration gives: "1ch" / "2ch", J§1.2), else, when no variant is
//     given, the first candidate (its plan decides by what it finds);
//   * the standby of a hot-standby pair, which reads nothing itself: the
//     identity the master's 0x1018 reads told it (vendor and product), else
//     the configured model (its vendor and first product code; for a model
//     whose product code is not checkable, the first description of its
//     vendor and family: ifm, F§7.3).
// Both fail with an Error naming what is missing (kNotFound: no
// description; kUnsupported: a description of no known family).
//
// Thread: any (pure functions over the catalog, which is not changed).
#pragma once

#include "base/result.hpp"
#include "canopen/lss.hpp"
#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "device/family_profile.hpp"

namespace cobridge::bus {

struct DescriptionChoice {
  const device::DeviceDescription* description = nullptr;  // owned by the catalog
  device::FamilyProfile profile;
};

// A device identified as `identity`, configured as `cfg`.
[[nodiscard]] Result<DescriptionChoice> choose_description(const device::DeviceCatalog& catalog,
                                                           const config::Device& cfg,
                                                           const canopen::LssAddress& identity);
// The standby's choice for a device it only heard: `identity` as far as
// the master's reads told it (vendor and product 0: not heard), else `cfg`'s
// model.
[[nodiscard]] Result<DescriptionChoice> description_from_config(const device::DeviceCatalog& catalog,
                                                                const config::Device& cfg,
                                                                const canopen::LssAddress& identity);

}  // namespace cobridge::bus
