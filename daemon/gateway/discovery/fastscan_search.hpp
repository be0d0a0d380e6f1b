// Fastscan search: which LSS searches look for the non-configured devices
// (node-ID FFh) of one bus, and the devices nobody configured that they
// keep finding.
//
// Non-configured devices are found by Fastscan (CiA 305; only V3 slaves
// answer) once "identify non-configured remote slave" was answered. A
// configured device that is not present is looked for by its known identity
// first (one Fastscan per product code its model may report, confirming whole
// fields with BitChecked 0 instead of searching 128 bits; a stranger never
// answers it), then the general Fastscan finds the smallest address left.
// When identify non-configured is answered but Fastscan finds nobody,
// Slowscan over the pre-Fastscan products looks for them (the Novotechnik
// rotary series, DSP-305 V1.1.2); in a clash, Slowscan separates the
// pre-Fastscan devices seen there.
//
// Devices nobody configured. A non-configured device the configuration does
// not name (or one that refuses its node-ID) is reported once with its
// identity and remembered, so that Fastscan, which always finds the smallest
// address first, is not run for it again and again: the general Fastscan
// backs off (doubling, from the discovery period up to 10 min) while the
// targeted ones still run every period.
//
// This is the place to narrow the search by what is known (issue 11 item 1):
// searches() decides which Fastscans run.
//
// Thread: the bus's control thread.
#pragma once

#include "canopen/lss_master.hpp"
#include "config/config.hpp"
#include "gateway/discovery/bus_picture.hpp"
#include "gateway/discovery/lss_task.hpp"
#include "gateway/discovery/report.hpp"

#include <cstdint>
#include <vector>

namespace cobridge::gateway::discovery {

class FastscanSearch {
 public:
  explicit FastscanSearch(Report& report) : report_(report) {}

  // The Fastscans to run now that identify non-configured was answered:
  // the targeted ones for the configured devices not present, then the
  // general one unless it is backing off.
  [[nodiscard]] std::vector<Task> searches(canopen::TimePoint now, const std::vector<config::Device>& devices,
                                           const BusPicture& picture) const;
  // Fastscan confirms these fields whole instead of searching them.
  [[nodiscard]] static canopen::LssMaster::FastscanKnown known_fields(const LssAddress& a);

  // Slowscan over every pre-Fastscan product, for non-configured devices
  // of unknown identity.
  [[nodiscard]] static std::vector<Task> slowscan_all_pre_fastscan();
  // One Slowscan per pre-Fastscan vendor/product among the answers `seen`
  // at clash node `n`. `non_configured`: (c) took the node-IDs away, what is
  // found has none.
  [[nodiscard]] static std::vector<Task> slowscan_of(const IdentityAnswers& seen, std::uint8_t n,
                                                     bool non_configured);

  [[nodiscard]] bool is_stranger(const LssAddress& a) const;
  // Reports a device left non-configured (once) and remembers it.
  void note_stranger(const LssAddress& a, const std::string& why);
  // The general Fastscan found a stranger again: it is all it finds first.
  void back_off(canopen::TimePoint now, canopen::Duration discovery_period);

 private:
  Report& report_;
  std::vector<LssAddress> strangers_;
  canopen::TimePoint general_not_before_{};
  canopen::Duration general_backoff_{};
};

}  // namespace cobridge::gateway::discovery
