#include "bus/timeline_journal.hpp"

#include "base/field_text.hpp"
#include "base/number_text.hpp"
#include "sys/atomic_file.hpp"
#include "sys/guarded_file.hpp"

#include <algorithm>
#include <cstdint>

namespace cobridge::bus {

namespace {

using Clock = std::chrono::system_clock;

std::int64_t ms_of(Clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
}

Clock::time_point time_of(std::uint64_t ms) { return Clock::time_point(std::chrono::milliseconds(ms)); }

// A bus name as a file name: letters, digits, '.', '_', '-' as they are.
std::string file_name_of(std::string_view bus) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : bus) {
    const auto u = static_cast<unsigned char>(c);
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                       c == '-' || (c == '.' && !out.empty());
    if (plain) {
      out += c;
    } else {
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 0x0F];
    }
  }
  return out + ".timeline";
}

// The latest time the clock can hold, in ms: system_clock counts
// nanoseconds in 64 bits (2262-04-11). A later `at=` would overflow it.
constexpr std::uint64_t kMaxMs =
    static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(Clock::duration::max()).count());

// kInvalidArgument for a value that is no time the clock holds.
Error read_ms(const std::string& key, const std::string& value, Clock::time_point& out) {
  std::uint64_t ms = 0;
  if (parse_unsigned(value, kMaxMs, ms)) {
    out = time_of(ms);
    return {};
  }
  return Error(Errc::kInvalidArgument, parse_unsigned(value, UINT64_MAX, ms)
                                           ? "'" + key + "' is after the year 2262, the clock's end"
                                           : "'" + key + "' cannot be '" + value + "'");
}

// An event's text as written: cut to the bound, so that its line fits.
std::string_view bounded_text(const std::string& text) {
  return std::string_view(text).substr(0, TimelineJournal::kMaxTextBytes);
}

// One field into `line`; kInvalidArgument for a value that does not read.
Error store_field(const std::string& key, const std::string& value, TimelineJournal::Line& line) {
  TimelineEvent& e = line.event;
  if (key == "at") return read_ms(key, value, e.at);
  if (key == "last") return read_ms(key, value, e.last_at);
  std::uint64_t n = 0;
  bool good = true;
  if (key == "device") {
    line.device = value;
  } else if (key == "kind") {
    good = parse_timeline_kind(value, e.kind);
  } else if (key == "repeats") {
    good = parse_unsigned(value, UINT32_MAX, n) && n > 0;
    e.repeats = static_cast<std::uint32_t>(n);
  } else if (key == "capture") {
    e.capture = value;
  } else if (key == "text") {
    e.text = value;
  }  // a newer gateway may add fields; an older one keeps the line
  if (!good) return Error(Errc::kInvalidArgument, "'" + key + "' cannot be '" + value + "'");
  return {};
}

// The device's events as load() builds them: a line with the `at` and kind
// of the latest event is a repeat count of it and replaces it.
void take(std::vector<TimelineEvent>& events, TimelineEvent e) {
  if (!events.empty() && events.back().at == e.at && events.back().kind == e.kind) {
    events.back() = std::move(e);
    return;
  }
  if (events.size() >= kTimelineLength) events.erase(events.begin());
  events.push_back(std::move(e));
}

}  // namespace

TimelineJournal::TimelineJournal(const std::filesystem::path& state_dir, std::string_view bus)
    : path_(state_dir / "timelines" / file_name_of(bus)) {}

std::string TimelineJournal::format_line(const std::string& device, const TimelineEvent& e) {
  std::string line = "at=" + std::to_string(ms_of(e.at));
  line += " device=" + escape_field(device);
  line += " kind=" + std::string(to_string(e.kind));
  line += " repeats=" + std::to_string(e.repeats);
  line += " last=" + std::to_string(ms_of(e.last_at));
  if (!e.capture.empty()) line += " capture=" + escape_field(e.capture);
  line += " text=" + escape_field(bounded_text(e.text));
  return line;
}

Result<TimelineJournal::Line> TimelineJournal::parse_line(std::string_view text) {
  Result<Fields> fields = split_fields(text);
  if (!fields.ok()) return fields.error();
  Line line;
  bool has_at = false;
  bool has_kind = false;
  for (const auto& [key, value] : *fields) {
    if (Error err = store_field(key, value, line)) return err;
    has_at = has_at || key == "at";
    has_kind = has_kind || key == "kind";
  }
  if (!has_at || !has_kind || line.device.empty()) {
    return Error(Errc::kInvalidArgument, "an event needs at=, kind= and device=");
  }
  if (line.event.last_at < line.event.at) line.event.last_at = line.event.at;
  return line;
}

Error TimelineJournal::load(std::map<std::string, std::vector<TimelineEvent>>& out) {
  out.clear();
  lines_ = 0;
  compact_next_ = false;
  // The newest part of an oversized file: the events that matter now.
  const Result<sys::FileText> file = sys::read_file_bounded(path_, kMaxLoadBytes, sys::KeepEnd::tail);
  if (!file.ok()) return file.error().kind == Errc::kNotFound ? Error{} : file.error();
  std::string_view text = file->text;
  std::string problems;
  if (file->skipped != 0) {
    // The cut fell inside a line: the piece before the first newline goes.
    const std::size_t newline = text.find('\n');
    text.remove_prefix(newline == std::string_view::npos ? text.size() : newline + 1);
    compact_next_ = true;
    problems += path_.string() + ": " + std::to_string(file->size) + " bytes, more than the " +
                std::to_string(kMaxLoadBytes) + " read; the oldest " + std::to_string(file->skipped) +
                " bytes skipped (line numbers below count from there; the file is rewritten from memory at the "
                "next write)\n";
  }
  load_lines(text, out, problems);
  if (problems.empty()) return {};
  problems.pop_back();
  return Error(Errc::kInvalidArgument, "lines skipped:\n" + problems, path_.string());
}

void TimelineJournal::load_lines(std::string_view text, std::map<std::string, std::vector<TimelineEvent>>& out,
                                 std::string& problems) {
  std::size_t bad = 0;
  std::string why;
  std::uint32_t number = 0;
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    ++lines_;
    if (line.empty() || line[0] == '#') continue;
    if (line.size() > kMaxLineBytes) {
      why = std::to_string(line.size()) + " bytes, longer than the " + std::to_string(kMaxLineBytes) +
            " a line may have";
    } else if (Result<Line> parsed = parse_line(line); parsed.ok()) {
      take(out[parsed->device], std::move(parsed->event));
      continue;
    } else {
      why = std::move(parsed).error().message;
    }
    if (++bad <= kProblemsNamed)
      problems += path_.string() + ":" + std::to_string(number) + ": " + log_excerpt(why, 120) + " (line skipped)\n";
  }
  if (bad > kProblemsNamed) problems += std::to_string(bad - kProblemsNamed) + " more lines skipped\n";
}

void TimelineJournal::queue_event(Queue& queue, const std::string& device, const TimelineEvent& e) {
  if (!queue.empty()) {
    auto& [last_device, last] = queue.back();
    if (last_device == device && last.at == e.at && last.kind == e.kind) {
      last = e;
      return;
    }
  }
  if (queue.size() >= kMaxQueued) queue.erase(queue.begin());
  queue.emplace_back(device, e);
}

Error TimelineJournal::flush(const Devices& devices, bool sync) {
  if (queue_.empty()) return {};
  std::size_t kept = 0;
  for (const auto& [name, timeline] : devices) kept += timeline.size();
  // Never from no timelines at all: that would write the history away.
  if (!devices.empty() &&
      (compact_next_ || lines_ + queue_.size() > kCompactFactor * std::max(kept, kTimelineLength)))
    return compact(devices);
  std::string text;
  for (const auto& [device, e] : queue_) text += format_line(device, e) + '\n';
  if (Error err = sys::append_to_file(path_, text, sync)) return err;
  unsynced_ = !sync;
  lines_ += queue_.size();
  queue_.clear();
  return {};
}

Error TimelineJournal::sync() {
  if (!unsynced_) return {};
  if (Error err = sys::append_to_file(path_, {}, true)) return err;
  unsynced_ = false;
  return {};
}

Error TimelineJournal::compact(const Devices& devices) {
  std::string text = "# cobridge device timelines; written by cobridged\n";
  std::size_t lines = 1;
  for (const auto& [name, timeline] : devices) {
    for (const TimelineEvent& e : timeline) {
      text += format_line(name, e) + '\n';
      ++lines;
    }
  }
  if (Error err = sys::write_file_atomically(path_, text)) return err;
  lines_ = lines;
  compact_next_ = false;
  unsynced_ = false;
  queue_.clear();
  return {};
}

}  // namespace cobridge::bus
