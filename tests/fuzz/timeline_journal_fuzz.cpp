// Fuzz target: the timeline journal's reader (daemon/bus/timeline_journal.*,
// Reads bounded, at=/last= after 2262 refused without
// overflow). The bytes are a journal file's content; load() reads it back.
// Invariants (abort on violation), as timeline_journal.hpp promises:
//   * a regular file never fails to read: load() gives no error or
//     kInvalidArgument (lines skipped), never a crash or a sanitizer report;
//   * the report names at most kProblemsNamed lines, in printable text: the
//     file's content never reaches the log (a 16 MB journal once made a
//     9.3 MB warning line);
//   * every event loaded is well formed: a device name, a known kind,
//     repeats >= 1, at <= last, both times within the clock (no overflow),
//     at most kTimelineLength per device;
//   * what load() gives is what the writer writes: each device's events,
//     queued and flushed into a second journal, load back the same (an
//     event's text cut to kMaxTextBytes, as format_line cuts it).
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "fuzz_dir.hpp"
#include "bus/timeline_journal.hpp"

using namespace cobridge;
using bus::TimelineEvent;
using bus::TimelineJournal;
using Timelines = std::map<std::string, std::vector<TimelineEvent>>;

namespace {

bool well_formed(const TimelineEvent& e) {
  const auto zero = std::chrono::system_clock::time_point{};
  bus::TimelineKind kind{};
  return e.repeats >= 1 && e.at >= zero && e.last_at >= e.at && bus::parse_timeline_kind(to_string(e.kind), kind) &&
         kind == e.kind;
}

bool same(const TimelineEvent& a, const TimelineEvent& b) {
  return a.at == b.at && a.kind == b.kind && a.repeats == b.repeats && a.last_at == b.last_at &&
         a.capture == b.capture && a.text == b.text;
}

void check_report(const Error& e) {
  if (e.ok()) return;
  if (e.kind != Errc::kInvalidArgument) std::abort();
  std::size_t named = 0;
  for (const char c : e.message) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') ++named;
    else if (u < 0x20 || u >= 0x7F) std::abort();
  }
  // "lines skipped:", kProblemsNamed lines, "N more", maybe the size line.
  if (named > TimelineJournal::kProblemsNamed + 2) std::abort();
  if (e.message.size() > 4096) std::abort();
}

// The loaded events through the writer and back: the same timelines.
void check_rewrite(const std::filesystem::path& dir, const Timelines& loaded) {
  std::size_t count = 0;
  for (const auto& [device, events] : loaded) count += events.size();
  if (count > TimelineJournal::kMaxQueued) return;  // the queue would drop the oldest
  Timelines expected = loaded;
  TimelineJournal out(dir, "rewritten");
  for (auto& [device, events] : expected) {
    for (TimelineEvent& e : events) {
      out.note(device, e);
      e.text.resize(std::min(e.text.size(), TimelineJournal::kMaxTextBytes));
    }
  }
  if (out.flush({}, false)) std::abort();
  Timelines back;
  if (out.load(back)) std::abort();
  if (back.size() != expected.size()) std::abort();
  for (const auto& [device, events] : expected) {
    const auto& got = back[device];
    if (got.size() != events.size()) std::abort();
    for (std::size_t i = 0; i < events.size(); ++i)
      if (!same(got[i], events[i])) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path dir = fuzz::fresh_dir("timeline");
  TimelineJournal journal(dir, "fuzz");
  std::filesystem::create_directories(journal.path().parent_path());
  {
    std::ofstream file(journal.path(), std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  Timelines loaded;
  const Error e = journal.load(loaded);
  check_report(e);
  for (const auto& [device, events] : loaded) {
    if (device.empty() || events.empty() || events.size() > bus::kTimelineLength) std::abort();
    for (const TimelineEvent& ev : events)
      if (!well_formed(ev)) std::abort();
  }
  check_rewrite(dir, loaded);
  std::filesystem::remove_all(dir);
  return 0;
}
