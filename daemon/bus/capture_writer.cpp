#include "bus/capture_writer.hpp"

#include "sys/logging.hpp"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <system_error>

namespace cobridge::gateway {
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

std::string capture_json_list(const std::vector<std::string>& items) {
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i) out += ',';
    out += json_quote(items[i]);
  }
  return out + "]";
}

std::string capture_sidecar(const CaptureOptions& o, const CaptureInfo& c) {
  return "{\"bus\":" + json_quote(o.bus) + ",\"interface\":" + json_quote(o.interface) +
         ",\"name\":" + json_quote(c.name) + ",\"causes\":" + capture_json_list(c.causes) +
         ",\"devices\":" + capture_json_list(c.devices) + ",\"fault_ns\":" + std::to_string(c.fault_ns) +
         ",\"fault_utc\":" + json_quote(capture_utc_stamp(c.fault_ns)) + ",\"frames\":" + std::to_string(c.frames) +
         ",\"skipped\":" + std::to_string(c.skipped) + ",\"bytes\":" + std::to_string(c.bytes) + "}\n";
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
  info.fault_ns = static_cast<std::int64_t>(timegm(&utc)) * 1'000'000'000 + std::int64_t{millis} * 1'000'000;
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

CaptureWriter::CaptureWriter(CaptureOptions options, const can::FrameRecorder& recorder)
    : options_(std::move(options)), recorder_(recorder) {}

CaptureWriter::~CaptureWriter() { stop(); }

Error CaptureWriter::start() {
  std::error_code ec;
  std::filesystem::create_directories(options_.dir, ec);
  if (ec) return Error(Errc::kFailed, "cannot create the captures directory: " + ec.message(), options_.dir.string(), ec);
  if (thread_.joinable()) return {};
  // A capture cut short by a crash or power loss: never listed, never counted.
  const std::string prefix = capture_file_word(options_.bus) + "-";
  for (const auto& entry : std::filesystem::directory_iterator(options_.dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".part" && name.compare(0, prefix.size(), prefix) == 0)
      std::filesystem::remove(entry.path(), ec);
  }
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
    if (pending_.size() >= kMaxPending) return {};
    Pending p;
    // Named now, so that whoever reports the fault can say which file holds it.
    p.info.name = capture_file_word(options_.bus) + "-" + capture_utc_stamp(fault_ns) + "-" +
                  capture_file_word(cause) + ".log";
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

std::vector<CaptureInfo> CaptureWriter::poll(std::int64_t now_ns) {
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
  const can::RecorderWindow window = recorder_.snapshot(info.fault_ns - options_.before.count(), window_end_ns);
  if (info.name.empty())
    info.name = capture_file_word(options_.bus) + "-" + capture_utc_stamp(info.fault_ns) + "-" +
                capture_file_word(info.causes.front()) + ".log";
  info.frames = window.frames.size();
  info.skipped = window.skipped;
  // The whole text first: its size makes room under the cap before anything
  // is written, so the cap holds at every moment, not only after a write.
  std::string text;
  text.reserve(window.frames.size() * (28 + options_.interface.size()));
  for (const can::Frame& f : window.frames) text += candump_line(f, options_.interface);
  info.bytes = text.size();
  const std::string sidecar = capture_sidecar(options_, info);
  enforce_cap(text.size() + sidecar.size());
  const std::filesystem::path path = options_.dir / info.name;
  const std::filesystem::path partial = options_.dir / (info.name + ".part");
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) return Error(Errc::kFailed, "cannot open for writing", partial.string());
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.flush();
    if (!out) return Error(Errc::kFailed, "write failed (disk full?)", partial.string());
  }
  // The sidecar first, the log renamed last: a listed capture is whole and
  // has its sidecar.
  std::ofstream(options_.dir / (info.name.substr(0, info.name.size() - 4) + ".json"), std::ios::trunc) << sidecar;
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) return Error(Errc::kFailed, "cannot rename: " + ec.message(), path.string(), ec);
  return {};
}

namespace {

struct CaptureOnDisk {
  std::string stem;  // name without .log / .json
  std::uint64_t bytes = 0;
  bool has_log = false;
};

// This bus's captures in `dir`, oldest first (their names sort by time).
std::vector<CaptureOnDisk> captures_on_disk(const std::filesystem::path& dir, const std::string& prefix) {
  std::vector<CaptureOnDisk> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    const std::string ext = entry.path().extension().string();
    if (ext != ".log" && ext != ".json") continue;
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    if (name[prefix.size()] < '0' || name[prefix.size()] > '9') continue;  // another bus whose name extends ours
    const std::string stem = entry.path().stem().string();
    auto it = std::find_if(found.begin(), found.end(), [&](const CaptureOnDisk& c) { return c.stem == stem; });
    if (it == found.end()) it = found.insert(found.end(), CaptureOnDisk{stem, 0, false});
    std::error_code size_ec;
    const auto size = entry.file_size(size_ec);
    if (!size_ec) it->bytes += size;
    if (ext == ".log") it->has_log = true;
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.stem < b.stem; });
  return found;
}

}  // namespace

void CaptureWriter::enforce_cap(std::uint64_t room) {
  const std::string prefix = capture_file_word(options_.bus) + "-";
  std::vector<CaptureOnDisk> found = captures_on_disk(options_.dir, prefix);
  std::uint64_t total = room;
  for (const auto& c : found) total += c.bytes;
  // Oldest first; a capture that alone is over the cap is still written.
  for (std::size_t i = 0; i < found.size() && total > options_.cap_bytes; ++i) {
    std::error_code ec;
    std::filesystem::remove(options_.dir / (found[i].stem + ".log"), ec);
    std::filesystem::remove(options_.dir / (found[i].stem + ".json"), ec);
    total -= found[i].bytes;
    std::lock_guard lock(mutex_);
    std::erase_if(recent_, [&](const CaptureInfo& r) { return r.name == found[i].stem + ".log"; });
  }
}

std::vector<CaptureInfo> CaptureWriter::recent() const {
  const std::string prefix = capture_file_word(options_.bus) + "-";
  std::vector<CaptureInfo> out;
  std::lock_guard lock(mutex_);
  // What is on disk (also from an earlier run), with the details of those
  // this run wrote.
  for (const CaptureOnDisk& c : captures_on_disk(options_.dir, prefix)) {
    if (!c.has_log) continue;
    const std::string name = c.stem + ".log";
    auto it = std::find_if(recent_.begin(), recent_.end(), [&](const CaptureInfo& r) { return r.name == name; });
    if (it != recent_.end()) {
      out.push_back(*it);
    } else {
      CaptureInfo info = capture_from_name(name, prefix.size());
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

}  // namespace cobridge::gateway
