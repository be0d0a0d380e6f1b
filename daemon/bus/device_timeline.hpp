// DeviceTimeline: a device's recent events with their cause in words, so
// that status, the web page and `cobridge why` can tell why a device is in
// the state it is in, and which capture holds the frames.
//
// Threads: the bus's control thread appends (BusManager::Impl::add_event);
// the status copies travel to other threads as plain values.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::bus {

// What kind of event: the page colours by it and `cobridge why` groups by it.
enum class TimelineKind : std::uint8_t {
  state,       // the gateway's state of the device changed (text: from, to, why)
  boot_up,     // a boot-up message (CiA 301 §7.2.8.3.2.1)
  heartbeat,   // heartbeat / guarding lost or back, with the measured gap
  emcy,        // an emergency message, decoded per family
  sdo,         // an SDO abort or timeout (CiA 301 §7.2.4.3.17 text)
  mismatch,    // a configured object read back different (object, expected, read)
  lss,         // a commissioning (CiA 305) step failed or assigned a node-ID
  node_id,     // the device moved to another node-ID
  controller,  // the bus's CAN controller changed its error state
  drift,       // an object the configuration sets was written by a client
  configured,  // a configuration plan finished (written, verified, stored)
  gateway,     // the gateway started: the events before it are from the journal
};
[[nodiscard]] const char* to_string(TimelineKind k) noexcept;
// The kind to_string() names; false for any other text.
[[nodiscard]] bool parse_timeline_kind(std::string_view text, TimelineKind& out) noexcept;

struct TimelineEvent {
  std::chrono::system_clock::time_point at{};
  TimelineKind kind = TimelineKind::state;
  std::string text;     // the cause in words, complete on its own
  std::string capture;  // the flight recorder's file holding the frames; empty = none
  // The same event again soon after (an EMCY storm, a flapping heartbeat) is
  // counted on the first, so a storm cannot push the cause out of the window.
  std::uint32_t repeats = 1;
  std::chrono::system_clock::time_point last_at{};  // of the latest repeat
};
// Repeats of one event within this are counted, not appended.
inline constexpr std::chrono::seconds kTimelineRepeatWindow{10};

inline constexpr std::size_t kTimelineLength = 100;  // events kept per device

// A device's timeline as DeviceStatus carries it. Status snapshots are
// copied on every change of any device (BusManager::Impl::publish_all, up
// to once per loop turn under an EMCY storm), so the events are shared,
// immutable once made: a copy is one reference count, and add() makes a new
// list (at most kTimelineLength events) that later copies share.
// Threads: add() on the bus's control thread; copies and reads anywhere.
class DeviceTimeline {
 public:
  DeviceTimeline() = default;
  // Events kept from before (the journal), most recent last.
  explicit DeviceTimeline(std::vector<TimelineEvent> events);
  void add(TimelineEvent e);
  [[nodiscard]] const std::vector<TimelineEvent>& events() const noexcept;
  [[nodiscard]] auto begin() const noexcept { return events().begin(); }
  [[nodiscard]] auto end() const noexcept { return events().end(); }
  [[nodiscard]] std::size_t size() const noexcept { return events().size(); }
  [[nodiscard]] bool empty() const noexcept { return events().empty(); }

 private:
  std::shared_ptr<const std::vector<TimelineEvent>> events_;
};

// Appends `e`, dropping the oldest beyond kTimelineLength (most recent last),
// or counts it on the latest event when that is the same (kind, text; any
// EMCY after an EMCY) and began less than kTimelineRepeatWindow before.
void append_event(std::vector<TimelineEvent>& timeline, TimelineEvent e);

}  // namespace cobridge::bus
