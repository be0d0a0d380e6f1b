// TimelineSink: where the bus controller's timeline events of configured
// devices go to outlive a restart: TimelineJournalThread in the daemon
// (the journal file, written on its own thread), nothing or a test's
// recorder in unit tests. The controller notes each event and hands the
// timelines over at most once per TimelineJournal::kFlushInterval.
// Thread: the bus's control thread makes every call.
#pragma once

#include "bus/timeline_journal.hpp"

#include <map>
#include <string>
#include <vector>

namespace cobridge::bus {

class TimelineSink {
 public:
  // Per device, its events of the last run, as the journal kept them.
  using Kept = std::map<std::string, std::vector<TimelineEvent>>;

  virtual ~TimelineSink() = default;
  virtual void note(const std::string& device, const TimelineEvent& e) = 0;
  // Events were noted since the last hand-over.
  [[nodiscard]] virtual bool pending() const noexcept = 0;
  virtual void hand_over(TimelineJournal::Devices devices) = 0;
};

}  // namespace cobridge::bus
