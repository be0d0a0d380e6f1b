// BusManager::Impl: the devices' timelines and their journal on disk, so
// that the causes outlive a restart of the daemon. Control thread only
// (restore_timelines() runs in the constructor, before the thread starts);
// the disk writes run on the journal's own thread.
#include "bus/bus_manager_impl.hpp"

namespace cobridge::bus {

void BusManager::Impl::add_event(DeviceAgent& m, TimelineKind kind, std::string text, std::string capture) {
  m.st.timeline.add(TimelineEvent{wall_now(), kind, std::move(text), std::move(capture)});
  if (journal && m.in_config) journal->note(m.st.name, m.st.timeline.events().back());
  dirty = true;
}

void BusManager::Impl::add_bus_event(TimelineKind kind, const std::string& text, const std::string& capture) {
  for (auto& m : devices) {
    if (m.in_config) add_event(m, kind, "bus " + bus.name + ": " + text, capture);
  }
}

void BusManager::Impl::restore_timelines() {
  TimelineJournal file(state.path().parent_path(), bus.name);
  std::map<std::string, std::vector<TimelineEvent>> kept;
  if (Error err = file.load(kept)) log->warn("bus {}: timeline journal: {}", bus.name, err.to_string());
  journal = std::make_unique<TimelineJournalThread>(std::move(file), bus.name);
  for (auto& m : devices) {
    auto it = kept.find(m.st.name);
    const bool history = it != kept.end() && !it->second.empty();
    if (history) m.st.timeline = DeviceTimeline(std::move(it->second));
    add_event(m, TimelineKind::gateway,
              history ? "gateway started; the events before are from its journal" : "gateway started");
  }
}

TimePoint BusManager::Impl::flush_timelines(TimePoint now, bool force) {
  if (!journal || !journal->pending()) return kNever;
  if (!force && now < journal_due) return journal_due;
  TimelineJournal::Devices all;
  for (const auto& m : devices) {
    if (m.in_config) all.emplace_back(m.st.name, m.st.timeline);
  }
  journal->hand_over(std::move(all));
  journal_due = now + TimelineJournal::kFlushInterval;
  return kNever;
}

}  // namespace cobridge::bus
