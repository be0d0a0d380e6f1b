// BusController: the devices' timelines, handed to the journal (a
// TimelineSink: on disk in the daemon, so that the causes outlive a
// restart). Control thread only (restore_timelines() runs in the
// constructor, before the thread starts).
#include "bus/bus_controller.hpp"

namespace cobridge::bus {

void BusController::add_event(DeviceAgent& m, TimelineKind kind, std::string text, std::string capture) {
  m.st.timeline.add(TimelineEvent{wall_now(), kind, std::move(text), std::move(capture)});
  if (journal && m.in_config) journal->note(m.st.name, m.st.timeline.events().back());
  dirty = true;
}

void BusController::add_bus_event(TimelineKind kind, const std::string& text, const std::string& capture) {
  for (auto& m : devices) {
    if (m.in_config) add_event(m, kind, "bus " + bus.name + ": " + text, capture);
  }
}

void BusController::restore_timelines(TimelineSink::Kept kept) {
  for (auto& m : devices) {
    auto it = kept.find(m.st.name);
    const bool history = it != kept.end() && !it->second.empty();
    if (history) m.st.timeline = DeviceTimeline(std::move(it->second));
    add_event(m, TimelineKind::gateway,
              history ? "gateway started; the events before are from its journal" : "gateway started");
  }
}

TimePoint BusController::flush_timelines(TimePoint now, bool force) {
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
