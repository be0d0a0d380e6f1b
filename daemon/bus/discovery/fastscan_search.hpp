// Fastscan search: which LSS searches look for the non-configured devices
// (node-ID FFh) of one bus, and the devices nobody configured that they
// keep finding.
//
// Non-configured devices are found by Fastscan (CiA 305; only V3 slaves
// answer) once "identify non-configured remote slave" was answered. Every
// Fastscan is guided by what is known (FastscanKnowledge):
// the configured devices not present (vendor, product, serial, and the
// revision the state file remembers) are confirmed whole with BitChecked 0
// instead of searched bit by bit; the general Fastscan also prefers the
// configured models and searches what nobody names (strangers, last). While
// the general scan backs off, a targeted one looks for the configured devices
// only. When identify non-configured is answered but Fastscan finds nobody,
// Slowscan over the pre-Fastscan products looks for them (the Novotechnik
// rotary series, DSP-305 V1.1.2, which never answers Fastscan); in a clash,
// Slowscan separates the pre-Fastscan devices seen there.
//
// Devices nobody configured. A non-configured device the configuration does
// not name (or one that refuses its node-ID) is reported once with its
// identity and remembered; the guided general scan finds it only after every
// configured model, and would find it first again, so the general Fastscan
// backs off at once (doubling, from the discovery period up to 10 min) while
// the targeted one still runs every period: a stranger is searched once.
//
// Thread: the bus's control thread.
#pragma once

#include "canopen/fastscan_plan.hpp"
#include "config/config.hpp"
#include "bus/discovery/bus_picture.hpp"
#include "bus/discovery/decisions.hpp"
#include "bus/discovery/lss_task.hpp"
#include "bus/discovery/report.hpp"
#include "bus/state_store.hpp"

#include <cstdint>
#include <vector>

namespace cobridge::bus::discovery {

class FastscanSearch {
 public:
  explicit FastscanSearch(Report& report) : report_(report) {}

  // The Fastscan to run now that identify non-configured was answered: the
  // general one, unless it is backing off; then the targeted one, if a
  // configured device is not present.
  [[nodiscard]] std::vector<Task> searches(canopen::TimePoint now, const BusSettings& s,
                                           const BusPicture& picture) const;
  // What a Fastscan knows before it starts. `known`: whole identities (a
  // clash's devices made non-configured); `found`: found in this run already.
  [[nodiscard]] static canopen::FastscanPlan plan(bool general, const BusSettings& s, const BusPicture& picture,
                                                  const std::vector<LssAddress>& known,
                                                  const std::vector<LssAddress>& found);

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
  // The general Fastscan found a stranger: it is all it would find first.
  void back_off(canopen::TimePoint now, canopen::Duration discovery_period);

 private:
  Report& report_;
  std::vector<LssAddress> strangers_;
  canopen::TimePoint general_not_before_{};
  canopen::Duration general_backoff_{};
};

}  // namespace cobridge::bus::discovery
