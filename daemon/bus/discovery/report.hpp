// What discovery tells the bus manager: its events (each problem text once
// per session, so a periodic probe does not repeat it) and the time, LSS
// exchanges and timeouts of each step.
//
// Thread: the bus's control thread; the bus manager takes both queues.
#pragma once

#include "canopen/lss_master.hpp"
#include "bus/device_status.hpp"
#include "bus/discovery.hpp"

#include <set>
#include <string>
#include <utility>
#include <vector>

namespace cobridge::bus::discovery {

class Report {
 public:
  void event(DiscoveryEvent e) { events_.push_back(std::move(e)); }
  // Something an operator must know; a text already reported is dropped.
  void problem(std::string text, std::uint8_t node = 0, const canopen::LssAddress& id = {});
  void timing(std::string step, std::string device, canopen::Duration d);
  // An LSS operation's step: also how many exchanges it took and how many of
  // them waited out a timeout (how each device was found).
  void timing(std::string step, std::string device, const canopen::LssMaster::Result& r);

  [[nodiscard]] std::vector<DiscoveryEvent> take_events() { return std::exchange(events_, {}); }
  [[nodiscard]] std::vector<StepTiming> take_timings() { return std::exchange(timings_, {}); }

 private:
  std::set<std::string> reported_problems_;
  std::vector<DiscoveryEvent> events_;
  std::vector<StepTiming> timings_;
};

}  // namespace cobridge::bus::discovery
