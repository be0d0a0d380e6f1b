#include "bus/device_timeline.hpp"

namespace cobridge::bus {

const char* to_string(TimelineKind k) noexcept {
  switch (k) {
    case TimelineKind::state: return "state";
    case TimelineKind::boot_up: return "boot-up";
    case TimelineKind::heartbeat: return "heartbeat";
    case TimelineKind::emcy: return "emcy";
    case TimelineKind::sdo: return "sdo";
    case TimelineKind::mismatch: return "mismatch";
    case TimelineKind::lss: return "lss";
    case TimelineKind::node_id: return "node-id";
    case TimelineKind::controller: return "controller";
    case TimelineKind::drift: return "drift";
    case TimelineKind::configured: return "configured";
    case TimelineKind::gateway: return "gateway";
  }
  return "?";
}

bool parse_timeline_kind(std::string_view text, TimelineKind& out) noexcept {
  for (unsigned k = 0; k <= static_cast<unsigned>(TimelineKind::gateway); ++k) {
    if (text == to_string(static_cast<TimelineKind>(k))) {
      out = static_cast<TimelineKind>(k);
      return true;
    }
  }
  return false;
}

void append_event(std::vector<TimelineEvent>& timeline, TimelineEvent e) {
  if (!timeline.empty()) {
    TimelineEvent& last = timeline.back();
    // EMCYs of a storm differ in their codes; the first names the cause.
    const bool same = last.text == e.text || e.kind == TimelineKind::emcy;
    if (last.kind == e.kind && same && e.at - last.at < kTimelineRepeatWindow && e.at >= last.at) {
      ++last.repeats;
      last.last_at = e.at;
      if (last.capture.empty()) last.capture = std::move(e.capture);
      return;
    }
  }
  e.last_at = e.at;
  if (timeline.size() >= kTimelineLength) timeline.erase(timeline.begin());
  timeline.push_back(std::move(e));
}

DeviceTimeline::DeviceTimeline(std::vector<TimelineEvent> events) {
  if (events.size() > kTimelineLength)
    events.erase(events.begin(), events.end() - static_cast<std::ptrdiff_t>(kTimelineLength));
  if (!events.empty()) events_ = std::make_shared<const std::vector<TimelineEvent>>(std::move(events));
}

void DeviceTimeline::add(TimelineEvent e) {
  auto next = events_ ? std::make_shared<std::vector<TimelineEvent>>(*events_)
                      : std::make_shared<std::vector<TimelineEvent>>();
  append_event(*next, std::move(e));
  events_ = std::move(next);
}

const std::vector<TimelineEvent>& DeviceTimeline::events() const noexcept {
  static const std::vector<TimelineEvent> kNone;
  return events_ ? *events_ : kNone;
}

}  // namespace cobridge::bus
