#include "bus/timeline_journal.hpp"

#include "base/field_text.hpp"
#include "base/number_text.hpp"
#include "sys/atomic_file.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>

namespace cobridge::gateway {

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

bool read_ms(const std::string& value, Clock::time_point& out) {
  std::uint64_t ms = 0;
  if (!parse_unsigned(value, UINT64_MAX, ms)) return false;
  out = time_of(ms);
  return true;
}

// One field into `e`; false with `why` for a value that does not read.
bool store_field(const std::string& key, const std::string& value, std::string& device, TimelineEvent& e,
                 std::string& why) {
  std::uint64_t n = 0;
  bool good = true;
  if (key == "at") {
    good = read_ms(value, e.at);
  } else if (key == "last") {
    good = read_ms(value, e.last_at);
  } else if (key == "device") {
    device = value;
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
  if (!good) why = "'" + key + "' cannot be '" + value + "'";
  return good;
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
  line += " text=" + escape_field(e.text);
  return line;
}

bool TimelineJournal::parse_line(std::string_view line, std::string& device, TimelineEvent& e, std::string& why) {
  Fields fields;
  if (!split_fields(line, fields, why)) return false;
  device.clear();
  e = TimelineEvent{};
  bool has_at = false;
  bool has_kind = false;
  for (const auto& [key, value] : fields) {
    if (!store_field(key, value, device, e, why)) return false;
    has_at = has_at || key == "at";
    has_kind = has_kind || key == "kind";
  }
  if (!has_at || !has_kind || device.empty()) {
    why = "an event needs at=, kind= and device=";
    return false;
  }
  if (e.last_at < e.at) e.last_at = e.at;
  return true;
}

Error TimelineJournal::load(std::map<std::string, std::vector<TimelineEvent>>& out) {
  out.clear();
  lines_ = 0;
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) return {};
  std::ifstream in(path_, std::ios::binary);
  if (!in) return Error(Errc::kFailed, "cannot be read", path_.string());
  std::string line;
  std::string problems;
  std::string device;
  std::string why;
  TimelineEvent e;
  for (std::uint32_t number = 1; std::getline(in, line); ++number) {
    ++lines_;
    if (line.empty() || line[0] == '#') continue;
    if (!parse_line(line, device, e, why)) {
      problems += path_.string() + ":" + std::to_string(number) + ": " + why + " (line skipped)\n";
      continue;
    }
    take(out[device], std::move(e));
  }
  if (in.bad()) return Error(Errc::kFailed, "read error", path_.string());
  if (problems.empty()) return {};
  problems.pop_back();
  return Error(Errc::kInvalidArgument, "lines skipped:\n" + problems, path_.string());
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

Error TimelineJournal::flush(const Devices& devices) {
  if (queue_.empty()) return {};
  std::size_t kept = 0;
  for (const auto& [name, timeline] : devices) kept += timeline.size();
  // Never from no timelines at all: that would write the history away.
  if (!devices.empty() && lines_ + queue_.size() > kCompactFactor * std::max(kept, kTimelineLength))
    return compact(devices);
  std::string text;
  for (const auto& [device, e] : queue_) text += format_line(device, e) + '\n';
  if (Error err = sys::append_to_file(path_, text)) return err;
  lines_ += queue_.size();
  queue_.clear();
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
  queue_.clear();
  return {};
}

}  // namespace cobridge::gateway
