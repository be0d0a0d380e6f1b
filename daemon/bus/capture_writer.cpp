#include "bus/capture_writer.hpp"

#include "base/json_writer.hpp"
#include "sys/guarded_file.hpp"
#include "sys/logging.hpp"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <system_error>

namespace cobridge::bus {
namespace {

constexpr std::uint32_t kCanErrFlag = 0x20000000u;  // linux/can.h CAN_ERR_FLAG
constexpr std::size_t kMaxPending = 16;

std::int64_t capture_wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// 20261128T015512.345Z: sortable, and free of ':' (file names on any system).
std::string capture_utc_stamp(std::int64_t ns) {
  const std::time_t seconds = static_cast<std::time_t>(ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[40];
  const int millis = static_cast<int>((ns / 1'000'000) % 1000);
  std::snprintf(text, sizeof text, "%04d%02d%02dT%02d%02d%02d.%03dZ", utc.tm_year + 1900, utc.tm_mon + 1,
                utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, millis);
  return text;
}

// <bus>-<stamp>-<cause>.log: the bus's name as configured (its letters are
// those of a file name), so that no two buses share a prefix.
std::string capture_name(const std::string& bus, std::int64_t fault_ns, std::string_view cause) {
  return bus + "-" + capture_utc_stamp(fault_ns) + "-" + capture_file_word(cause) + ".log";
}

// "YYYYMMDDTHHMMSS.mmmZ" at the start of `text`.
bool is_stamp(std::string_view text) {
  static constexpr std::string_view kForm = "########T######.###Z";
  if (text.size() < kForm.size()) return false;
  for (std::size_t i = 0; i < kForm.size(); ++i) {
    const bool digit = text[i] >= '0' && text[i] <= '9';
    if (kForm[i] == '#' ? !digit : text[i] != kForm[i]) return false;
  }
  return true;
}

void write_list(JsonWriter& w, std::string_view key, const std::vector<std::string>& items) {
  w.key(key).begin_array();
  for (const auto& item : items) w.value(item);
  w.end_array();
}

// "gaps": [{"line":K,"dropped":N},...], the gaps the kernel's drops left.
void write_gaps(JsonWriter& w, const std::vector<std::pair<std::size_t, std::uint32_t>>& gaps) {
  w.key("gaps").begin_array();
  for (const auto& [line, dropped] : gaps) w.begin_object().field("line", line).field("dropped", dropped).end_object();
  w.end_array();
}

std::string capture_sidecar(const CaptureOptions& o, const CaptureInfo& c) {
  JsonWriter w;
  w.begin_object().field("bus", o.bus).field("interface", o.interface).field("name", c.name);
  write_list(w, "causes", c.causes);
  write_list(w, "devices", c.devices);
  w.field("fault_ns", c.fault_ns).field("fault_utc", capture_utc_stamp(c.fault_ns)).field("frames", c.frames);
  w.field("skipped", c.skipped).field("kernel_drops", c.kernel_drops);
  write_gaps(w, c.gaps);
  w.field("bytes", c.bytes).end_object();
  return w.take() + "\n";
}

}  // namespace

std::string candump_line(const can::Frame& frame, std::string_view interface) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  const std::int64_t ns = frame.timestamp_ns < 0 ? 0 : frame.timestamp_ns;
  char head[48];
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(ns / 1'000'000'000),
                static_cast<long long>((ns / 1000) % 1'000'000));
  std::string line = head;
  line += interface;
  line += ' ';
  char id[16];
  if (frame.is_error()) {
    std::snprintf(id, sizeof id, "%08X", static_cast<unsigned>((frame.id & 0x1FFFFFFFu) | kCanErrFlag));
  } else if (frame.is_extended()) {
    std::snprintf(id, sizeof id, "%08X", static_cast<unsigned>(frame.id & 0x1FFFFFFFu));
  } else {
    std::snprintf(id, sizeof id, "%03X", static_cast<unsigned>(frame.id & 0x7FFu));
  }
  line += id;
  line += '#';
  if (frame.is_rtr()) {
    line += 'R';
  } else {
    for (std::uint8_t i = 0; i < frame.len && i < 8; ++i) {
      line += kHex[frame.data[i] >> 4];
      line += kHex[frame.data[i] & 0x0F];
    }
  }
  line += '\n';
  return line;
}

CaptureInfo capture_from_name(const std::string& name, std::size_t prefix) {
  CaptureInfo info;
  info.name = name;
  // "<bus>-YYYYMMDDTHHMMSS.mmmZ-<cause>.log": the stamp is 20 characters.
  if (name.size() < prefix + 25 || name.compare(name.size() - 4, 4, ".log") != 0) return info;
  std::tm utc{};
  int millis = 0;
  char t = 0;
  char z = 0;
  if (std::sscanf(name.c_str() + prefix, "%4d%2d%2d%c%2d%2d%2d.%3d%c", &utc.tm_year, &utc.tm_mon, &utc.tm_mday, &t,
                  &utc.tm_hour, &utc.tm_min, &utc.tm_sec, &millis, &z) != 9 || t != 'T' || z != 'Z')
    return info;
  utc.tm_year -= 1900;
  utc.tm_mon -= 1;
  // Nanoseconds since 1970 in 64 bits reach from 1677 to 2262: a name's
  // year 9999 (or 0000) would overflow them.
  const std::int64_t seconds = static_cast<std::int64_t>(timegm(&utc));
  constexpr std::int64_t kLimit = INT64_MAX / 1'000'000'000 - 1;
  if (seconds > kLimit || seconds < -kLimit) return info;
  info.fault_ns = seconds * 1'000'000'000 + std::int64_t{millis} * 1'000'000;
  std::string word = name.substr(prefix + 21, name.size() - 4 - (prefix + 21));
  std::replace(word.begin(), word.end(), '-', ' ');
  if (!word.empty()) info.causes.push_back(word);
  return info;
}

std::string capture_file_word(std::string_view cause) {
  std::string out;
  for (char c : cause) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
    if (keep) {
      out += c;
    } else if (c >= 'A' && c <= 'Z') {
      out += static_cast<char>(c - 'A' + 'a');
    } else if (!out.empty() && out.back() != '-') {
      out += '-';
    }
  }
  while (!out.empty() && out.back() == '-') out.pop_back();
  return out.empty() ? "fault" : out;
}

bool is_capture_of(std::string_view file_name, std::string_view bus, std::string_view ext) {
  const std::size_t stamp_at = bus.size() + 1;
  const std::size_t word_at = stamp_at + 21;  // the stamp's 20 characters and '-'
  if (file_name.size() <= word_at + ext.size()) return false;
  if (file_name.substr(0, bus.size()) != bus || file_name[bus.size()] != '-') return false;
  if (!is_stamp(file_name.substr(stamp_at)) || file_name[word_at - 1] != '-') return false;
  if (file_name.substr(file_name.size() - ext.size()) != ext) return false;
  const std::string_view word = file_name.substr(word_at, file_name.size() - ext.size() - word_at);
  return std::all_of(word.begin(), word.end(),
                     [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-'; });
}

CaptureWriter::CaptureWriter(CaptureOptions options, const can::FrameRecorder& recorder)
    : options_(std::move(options)), recorder_(recorder) {}

CaptureWriter::~CaptureWriter() { stop(); }

Error CaptureWriter::start() {
  std::error_code ec;
  std::filesystem::create_directories(options_.dir, ec);
  if (ec) return Error(Errc::kFailed, "cannot create the captures directory: " + ec.message(), options_.dir.string(), ec);
  if (thread_.joinable()) return {};
  // A capture cut short by a crash or power loss: never listed, never counted.
  for (const auto& entry : std::filesystem::directory_iterator(options_.dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".part" && is_capture_of(entry.path().stem().string(), options_.bus, ".log"))
      std::filesystem::remove(entry.path(), ec);  // a link itself, never what it names
  }
  warn_strangers();
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
  }
  thread_ = std::thread([this] { run(); });
  return {};
}

void CaptureWriter::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::string CaptureWriter::request(std::string cause, std::string device, std::int64_t fault_ns) {
  std::string name;
  {
    std::lock_guard lock(mutex_);
    for (Pending& p : pending_) {
      if (fault_ns < p.info.fault_ns || fault_ns > p.window_end_ns) continue;
      if (std::find(p.info.causes.begin(), p.info.causes.end(), cause) == p.info.causes.end())
        p.info.causes.push_back(std::move(cause));
      if (std::find(p.info.devices.begin(), p.info.devices.end(), device) == p.info.devices.end())
        p.info.devices.push_back(std::move(device));
      return p.info.name;
    }
    // Faults come in time order, so a new window opens at most once per
    // `after`; more than this waiting means the writer is stuck (disk).
    if (pending_.size() >= kMaxPending || !take_budget_locked(fault_ns)) return {};
    Pending p;
    // Named now, so that whoever reports the fault can say which file holds it.
    p.info.name = capture_name(options_.bus, fault_ns, cause);
    name = p.info.name;
    p.info.causes.push_back(std::move(cause));
    p.info.devices.push_back(std::move(device));
    p.info.fault_ns = fault_ns;
    p.window_end_ns = fault_ns + options_.after.count();
    pending_.push_back(std::move(p));
  }
  wake_.notify_all();
  return name;
}

bool CaptureWriter::take_budget_locked(std::int64_t now_ns) {
  roll_budget_locked(now_ns);
  if (!budget_.started) {
    budget_.started = true;
    budget_.hour_from_ns = now_ns;
  }
  if (budget_.made < options_.budget_per_hour) {
    ++budget_.made;
    return true;
  }
  ++budget_.skipped_total;
  if (budget_.skipped++ == 0)
    sys::logger("gateway")->warn(
        "bus {}: capture skipped: {} captures in the hour from {} (capture_budget_per_hour); those skipped until "
        "the hour ends are counted and logged then",
        options_.bus, budget_.made, capture_utc_stamp(budget_.hour_from_ns));
  return false;
}

void CaptureWriter::roll_budget_locked(std::int64_t now_ns) {
  constexpr std::int64_t kHour = 3600LL * 1'000'000'000;
  // A clock set back starts the hour again too.
  if (!budget_.started || (now_ns >= budget_.hour_from_ns && now_ns - budget_.hour_from_ns < kHour)) return;
  if (budget_.skipped > 0)
    sys::logger("gateway")->warn("bus {}: {} capture(s) skipped in the hour from {}: capture_budget_per_hour = {}",
                                 options_.bus, budget_.skipped, capture_utc_stamp(budget_.hour_from_ns),
                                 options_.budget_per_hour);
  budget_ = Budget{false, 0, 0, 0, budget_.skipped_total};
}

std::uint64_t CaptureWriter::skipped_over_budget() const {
  std::lock_guard lock(mutex_);
  return budget_.skipped_total;
}

std::vector<CaptureInfo> CaptureWriter::poll(std::int64_t now_ns) {
  {
    std::lock_guard lock(mutex_);
    roll_budget_locked(now_ns);
  }
  std::vector<CaptureInfo> written;
  for (;;) {
    Pending due;
    {
      std::lock_guard lock(mutex_);
      auto it = std::find_if(pending_.begin(), pending_.end(), [&](const Pending& p) { return p.window_end_ns <= now_ns; });
      if (it == pending_.end()) break;
      due = std::move(*it);
      pending_.erase(it);
    }
    if (Error e = write(due.info, due.window_end_ns)) {
      sys::logger("gateway")->warn("bus {}: capture not written: {}", options_.bus, e.to_string());
      continue;
    }
    if (due.info.kernel_drops != 0)
      sys::logger("gateway")->warn("bus {}: capture {} has {} gaps: the kernel dropped {} frames at the full receive "
                                   "queue (each gap's line and size in its sidecar)",
                                   options_.bus, due.info.name, due.info.gaps.size(), due.info.kernel_drops);
    {
      std::lock_guard lock(mutex_);
      recent_.push_back(due.info);
      while (recent_.size() > options_.recent_kept) recent_.pop_front();
    }
    written.push_back(std::move(due.info));
  }
  return written;
}

Error CaptureWriter::write(CaptureInfo& info, std::int64_t window_end_ns) {
  can::RecorderWindow window = recorder_.snapshot(info.fault_ns - options_.before.count(), window_end_ns);
  // Bus time order, not the socket's receive order: on a machine with more
  // than one CPU two frames can reach the socket in the other order than
  // their kernel stamps (the daemon's own request looped back on the
  // sending CPU beside a device's answer received on another), and
  // canplayer replays by the stamps' differences.
  std::stable_sort(window.frames.begin(), window.frames.end(),
                   [](const can::Frame& a, const can::Frame& b) { return a.timestamp_ns < b.timestamp_ns; });
  if (info.name.empty()) info.name = capture_name(options_.bus, info.fault_ns, info.causes.front());
  info.frames = window.frames.size();
  info.skipped = window.skipped;
  // The whole text first: its size makes room under the cap before anything
  // is written, so the cap holds at every moment, not only after a write.
  std::string text;
  text.reserve(window.frames.size() * (28 + options_.interface.size()));
  info.gaps.clear();
  info.kernel_drops = 0;
  for (std::size_t i = 0; i < window.frames.size(); ++i) {
    const can::Frame& f = window.frames[i];
    text += candump_line(f, options_.interface);
    if (f.dropped_before == 0) continue;  // before line 1: lost at most there, maybe before the window
    info.gaps.emplace_back(i + 1, f.dropped_before);
    info.kernel_drops += f.dropped_before;
  }
  info.bytes = text.size();
  const std::string sidecar = capture_sidecar(options_, info);
  enforce_cap(text.size() + sidecar.size());
  return write_files(info.name, text, sidecar);
}

Error CaptureWriter::write_files(const std::string& name, const std::string& text, const std::string& sidecar) {
  const std::filesystem::path path = options_.dir / name;
  const std::filesystem::path partial = options_.dir / (name + ".part");
  const std::filesystem::path side = options_.dir / (name.substr(0, name.size() - 4) + ".json");
  // Each file new (O_EXCL) and synced; the sidecar first, the log renamed
  // last, never over a name that exists: a listed capture is whole, has its
  // sidecar and is on the disk.
  Result<sys::OpenFile> log = sys::create_new_file(partial);
  if (!log.ok()) return log.error();
  Error e = sys::write_all(*log, text, partial);
  if (!e) e = sys::sync_file(*log, partial);
  log = sys::OpenFile();
  Result<sys::OpenFile> json = e ? Result<sys::OpenFile>(e) : sys::create_new_file(side);
  const bool made_side = json.ok();
  if (!e && !json.ok()) e = json.error();
  if (!e) e = sys::write_all(*json, sidecar, side);
  if (!e) e = sys::sync_file(*json, side);
  json = sys::OpenFile();
  if (!e) e = sys::rename_no_replace(partial, path);
  if (!e) return sys::sync_directory(options_.dir);
  std::error_code ec;
  std::filesystem::remove(partial, ec);  // ours: created above
  if (made_side) std::filesystem::remove(side, ec);
  return e;
}

namespace {

struct CaptureOnDisk {
  std::string stem;  // name without .log / .json
  std::uint64_t bytes = 0;
  bool has_log = false;   // a regular <stem>.log
  bool has_json = false;  // a regular <stem>.json
};

// Is `name` (.log or .json) a capture file of `bus`?
bool capture_file_of(const std::string& name, const std::string& bus) {
  return is_capture_of(name, bus, ".log") || is_capture_of(name, bus, ".json");
}

// This bus's captures in `dir`, oldest first (their names sort by time):
// regular files only, never what a link names.
std::vector<CaptureOnDisk> captures_on_disk(const std::filesystem::path& dir, const std::string& bus) {
  std::vector<CaptureOnDisk> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    const std::string ext = entry.path().extension().string();
    std::error_code type_ec;
    if (!capture_file_of(name, bus) || entry.symlink_status(type_ec).type() != std::filesystem::file_type::regular)
      continue;
    const std::string stem = entry.path().stem().string();
    auto it = std::find_if(found.begin(), found.end(), [&](const CaptureOnDisk& c) { return c.stem == stem; });
    if (it == found.end()) it = found.insert(found.end(), CaptureOnDisk{stem, 0, false, false});
    std::error_code size_ec;
    const auto size = entry.file_size(size_ec);
    if (!size_ec) it->bytes += size;
    (ext == ".log" ? it->has_log : it->has_json) = true;
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.stem < b.stem; });
  return found;
}

}  // namespace

void CaptureWriter::enforce_cap(std::uint64_t room) {
  warn_strangers();
  std::vector<CaptureOnDisk> found = captures_on_disk(options_.dir, options_.bus);
  std::uint64_t total = room;
  for (const auto& c : found) total += c.bytes;
  // Oldest first; a capture that alone is over the cap is still written.
  for (std::size_t i = 0; i < found.size() && total > options_.cap_bytes; ++i) {
    std::error_code ec;
    if (found[i].has_log) std::filesystem::remove(options_.dir / (found[i].stem + ".log"), ec);
    if (found[i].has_json) std::filesystem::remove(options_.dir / (found[i].stem + ".json"), ec);
    total -= found[i].bytes;
    std::lock_guard lock(mutex_);
    std::erase_if(recent_, [&](const CaptureInfo& r) { return r.name == found[i].stem + ".log"; });
  }
}

void CaptureWriter::warn_strangers() {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(options_.dir, ec)) {
    const std::string name = entry.path().filename().string();
    std::error_code type_ec;
    if (!capture_file_of(name, options_.bus) || entry.symlink_status(type_ec).type() == std::filesystem::file_type::regular)
      continue;
    if (std::find(strangers_.begin(), strangers_.end(), name) != strangers_.end()) continue;
    strangers_.push_back(name);
    sys::logger("gateway")->warn("bus {}: {}: {}; not listed, served or deleted (never followed)", options_.bus,
                                 entry.path().string(),
                                 entry.is_symlink(type_ec) ? "a symbolic link" : "not a regular file");
  }
}

Result<std::string> CaptureWriter::read(std::string_view name) const {
  const auto listed = recent();
  if (std::none_of(listed.begin(), listed.end(), [&](const CaptureInfo& c) { return c.name == name; }))
    return Error(Errc::kNotFound, "no capture \"" + std::string(name) + "\" (cobridge capture list shows them)");
  const std::filesystem::path path = options_.dir / std::string(name);
  Result<sys::FileText> file = sys::read_file_bounded(path, kMaxServedBytes);
  if (!file.ok()) return Error(Errc::kUnavailable, "cannot read the capture: " + file.error().message, path.string());
  if (file->skipped != 0)
    return Error(Errc::kUnavailable,
                 "the capture is " + std::to_string(file->size) + " bytes, more than the " +
                     std::to_string(kMaxServedBytes) + " served",
                 path.string());
  return std::move(file.value().text);
}

std::vector<CaptureInfo> CaptureWriter::recent() const {
  const std::size_t prefix = options_.bus.size() + 1;
  std::vector<CaptureInfo> out;
  std::lock_guard lock(mutex_);
  // What is on disk (also from an earlier run), with the details of those
  // this run wrote.
  for (const CaptureOnDisk& c : captures_on_disk(options_.dir, options_.bus)) {
    if (!c.has_log) continue;
    const std::string name = c.stem + ".log";
    auto it = std::find_if(recent_.begin(), recent_.end(), [&](const CaptureInfo& r) { return r.name == name; });
    if (it != recent_.end()) {
      out.push_back(*it);
    } else {
      CaptureInfo info = capture_from_name(name, prefix);
      std::error_code ec;
      info.bytes = std::filesystem::file_size(options_.dir / name, ec);
      out.push_back(std::move(info));
    }
  }
  return out;
}

std::size_t CaptureWriter::pending() const {
  std::lock_guard lock(mutex_);
  return pending_.size();
}

void CaptureWriter::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    // Wakes for a new request, and every 100 ms to see which windows closed:
    // a capture is on disk well within 1 s of its window's end.
    wake_.wait_for(lock, std::chrono::milliseconds(100));
    if (stopping_) break;
    if (pending_.empty()) continue;
    lock.unlock();
    (void)poll(capture_wall_ns());
    lock.lock();
  }
}

}  // namespace cobridge::bus
