// TimelineJournal: a bus's device timelines on disk, so that after the
// daemon restarts (an update, a crash, a power cut) `cobridge why` and the
// page still tell why a device dropped before it.
//
// File: <state_dir>/timelines/<bus>.timeline, one event per line in field
// text (base/field_text.hpp):
//   at=<ms since 1970> device=<name> kind=<kind> repeats=<n> last=<ms> capture=<file> text=<words>
// Lines are appended, batched: the control loop flushes at most once per
// kFlushInterval, so an EMCY storm costs one line per interval, not one per
// EMCY. The writer syncs the appends (fdatasync) at most every
// kSyncInterval and at a stop, the directory when the file is created, and
// a compaction whole: a power cut loses at most the last kSyncInterval.
// Syncing every append would write the flash once a second through a storm
// (and, in the User-Mode Linux test bed, hold the whole machine each time).
// A repeat of an event is written again
// with the same `at` and kind; on load the later line replaces the earlier.
// Once the file holds kCompactFactor times the events kept, it is rewritten
// atomically from the timelines in memory.
//
// Read and written as sys/guarded_file.hpp says: a symbolic link (or a FIFO)
// planted as the journal is refused with an error naming it, never followed.
// The read is bounded: of a file over kMaxLoadBytes only the newest
// kMaxLoadBytes are read (and the file is rewritten from memory at the next
// flush), a line over kMaxLineBytes is skipped; either is reported with the
// file and the size, never the content. A time the clock cannot hold (`at=`
// or `last=` after the year 2262) is a line that does not read.
//
// Thread: one thread at a time (TimelineJournalThread's writer thread in the
// daemon; the test's thread in unit tests).
#pragma once

#include "base/error.hpp"
#include "base/result.hpp"
#include "bus/device_timeline.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::bus {

class TimelineJournal {
 public:
  static constexpr std::chrono::seconds kFlushInterval{1};
  static constexpr std::chrono::seconds kSyncInterval{10};
  static constexpr std::size_t kCompactFactor = 4;
  // About four times what 127 devices keep (the file is compacted at four
  // times the events kept: some 40 kB a device).
  static constexpr std::uint64_t kMaxLoadBytes = 16u << 20;
  // An event's text is cut to kMaxTextBytes when written, so every line the
  // gateway writes fits.
  static constexpr std::size_t kMaxLineBytes = 4096;
  static constexpr std::size_t kMaxTextBytes = 1000;
  // The lines that do not read load() names (file:line: why) before it counts the rest.
  static constexpr std::size_t kProblemsNamed = 5;

  // The journal of bus `bus` under `state_dir`. The bus name is made safe
  // for a file name (%XX for anything but letters, digits, '.', '_', '-').
  TimelineJournal(const std::filesystem::path& state_dir, std::string_view bus);

  // Every device's events from the file, most recent last, at most
  // kTimelineLength each. A missing file: none. Malformed or overlong lines
  // are skipped, and the oldest part of an oversized file: then
  // kInvalidArgument says so (the first kProblemsNamed lines as file:line:
  // why, then how many more; the file's size) and the rest still counts.
  // An unreadable file (a symbolic link, an I/O error): kFailed.
  [[nodiscard]] Error load(std::map<std::string, std::vector<TimelineEvent>>& out);

  // Events waiting to be written: (device, event), oldest first.
  using Queue = std::vector<std::pair<std::string, TimelineEvent>>;
  static constexpr std::size_t kMaxQueued = 1000;
  // The device's latest event (new or counted as a repeat) into `queue`; a
  // repeat replaces its queued line; beyond kMaxQueued the oldest go.
  static void queue_event(Queue& queue, const std::string& device, const TimelineEvent& e);

  void note(const std::string& device, const TimelineEvent& e) { queue_event(queue_, device, e); }
  [[nodiscard]] bool pending() const noexcept { return !queue_.empty(); }

  // Appends the queued lines in one write. When the file has grown past
  // kCompactFactor x the events of `devices` (at least kTimelineLength),
  // rewrites it from `devices` instead (never from none). On a failure the queue is kept for
  // the next try. `devices`: the configured devices' timelines as they are
  // now (copies share the events; DeviceTimeline).
  // With `sync`, the file is on the disk when it returns (an append is
  // fdatasynced; a compaction always is).
  using Devices = std::vector<std::pair<std::string, DeviceTimeline>>;
  [[nodiscard]] Error flush(const Devices& devices, bool sync = true);
  // fdatasync of what earlier flushes appended without it (nothing to do: none).
  [[nodiscard]] Error sync();

  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

  // One event's line and its parser, exposed for tests.
  [[nodiscard]] static std::string format_line(const std::string& device, const TimelineEvent& e);
  // One line of the journal: a device's event.
  struct Line {
    std::string device;
    TimelineEvent event;
  };
  // kInvalidArgument, saying why, when the line is not an event.
  [[nodiscard]] static Result<Line> parse_line(std::string_view text);

 private:
  [[nodiscard]] Error compact(const Devices& devices);

  // The events of `text` into `out`; the lines that do not read into `problems`.
  void load_lines(std::string_view text, std::map<std::string, std::vector<TimelineEvent>>& out, std::string& problems);

  std::filesystem::path path_;
  Queue queue_;
  std::size_t lines_ = 0;  // lines in the file (as loaded and written since)
  bool compact_next_ = false;  // the file was too large to be read whole: rewrite it
  bool unsynced_ = false;      // appended without fdatasync since the last sync
};

}  // namespace cobridge::bus
