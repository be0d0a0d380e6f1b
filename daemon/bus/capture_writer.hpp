// CaptureWriter: writes the flight recorder's window around a fault of one
// bus to the state directory as a candump log, so that `canplayer` and log
// viewers replay it.
//
// A fault is requested with its wall-clock time; once `after` has passed
// since it, the writer takes the recorder's frames of [fault - before,
// fault + after] and writes <dir>/<bus>-<UTC time>-<cause>.log, one line per
// frame in the order of their kernel stamps, in `candump -l` form,
// "(SECONDS.MICROSECONDS) IFACE ID#DATA", with a
// sidecar <name>.json (bus, causes, devices, fault time, frames, bytes).
// candump logs have no comment lines, hence the sidecar. A fault inside the
// window of a capture still pending joins it (one file, every cause in the
// sidecar), so a storm of faults makes one file per window, not one per
// fault. Before each write the bus's oldest captures are deleted until its
// captures (logs and sidecars) and the new one fit in `cap_bytes`.
//
// The captures directory may hold what others put there. A bus's captures
// are the regular files named exactly <bus>-<stamp>-<word>.log/.json (the
// bus name as configured, then the stamp's digits: bus "a" never counts,
// lists or deletes a file of bus "a-1"); anything else is left alone. Files
// are opened as sys/guarded_file.hpp says: created with O_EXCL (a name
// planted where a capture goes is an error, never written through), read
// with O_NOFOLLOW (a symbolic link is neither listed nor served nor
// followed, and is named once in a warning); the log, its sidecar and then
// the directory are fsynced before the capture is listed or returned as
// written.
//
// The cap bounds the space, not the writes: a flash disk wears by what is
// written. At most `budget_per_hour` captures are made in an hour (the hour
// starts with its first capture); a fault that would open a window beyond
// it makes no capture: it is counted (skipped_over_budget()), the first one
// of the hour is logged, and when the hour is over one line gives the count.
//
// Threads: request(), recent() and pending() from any thread (a mutex, held
// only to copy or append); start()/stop() from the owner; the writer thread
// does the snapshot and the file I/O, never the caller. poll() is the
// writer thread's step, public for tests that run it without the thread.
#pragma once

#include "base/result.hpp"
#include "can/frame.hpp"
#include "can/frame_recorder.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

namespace cobridge::bus {

struct CaptureOptions {
  std::filesystem::path dir;   // <state_dir>/captures
  std::string bus;             // the bus's name, the file names' prefix
  std::string interface;       // written in every line (canplayer's source interface)
  std::chrono::nanoseconds before{std::chrono::seconds(10)};
  std::chrono::nanoseconds after{std::chrono::seconds(2)};
  std::uint64_t cap_bytes = 64ull << 20;  // this bus's captures on disk, at most
  std::uint32_t budget_per_hour = 60;     // captures written in an hour, at most (flash wear)
  std::size_t recent_kept = 32;           // captures recent() remembers
};

// One capture written (or, for recent(), found on disk).
struct CaptureInfo {
  std::string name;                  // file name, without directory
  std::vector<std::string> causes;   // in the order they came
  std::vector<std::string> devices;  // the devices concerned ("" for the bus)
  std::int64_t fault_ns = 0;         // the first fault's wall-clock time
  std::size_t frames = 0;
  std::size_t skipped = 0;           // slots overwritten while copied (none expected)
  // Where the file has gaps: frames the kernel dropped at the RX socket's
  // full queue (can::Frame::dropped_before), as (line of the frame after
  // the gap, 1-based; frames dropped). A replay or a comparison with
  // another trace knows exactly what is missing and where.
  std::vector<std::pair<std::size_t, std::uint32_t>> gaps;
  std::uint64_t kernel_drops = 0;    // the sum of the gaps
  std::uint64_t bytes = 0;           // the .log file's size
};

// "(1700000000.123456) vcan0 701#00": one candump -l line, newline included.
// Standard identifiers as 3 hex digits, extended (and error frames, with the
// CAN_ERR_FLAG bit) as 8; RTR frames as "ID#R".
[[nodiscard]] std::string candump_line(const can::Frame& frame, std::string_view interface);

// A capture of an earlier run as its file name tells it: the fault's time
// and its first cause ("heartbeat-lost" -> "heartbeat lost"); `prefix` is the
// length of "<bus>-". A name of another form, or a time the clock cannot
// hold (a year before 1678 or after 2261), gives the name only.
[[nodiscard]] CaptureInfo capture_from_name(const std::string& name, std::size_t prefix);

// Is `file_name` exactly a capture file of bus `bus` with extension `ext`
// (".log", ".json"): "<bus>-YYYYMMDDTHHMMSS.mmmZ-<word><ext>", the word of
// lowercase letters, digits and dashes. A name of another bus never is: a
// word holds no 'T' or '.', so no bus's stamp can hide in another's word.
[[nodiscard]] bool is_capture_of(std::string_view file_name, std::string_view bus, std::string_view ext);

// "boot-up", "heartbeat lost" -> "heartbeat-lost": what a cause is in a file name.
[[nodiscard]] std::string capture_file_word(std::string_view cause);

class CaptureWriter {
 public:
  CaptureWriter(CaptureOptions options, const can::FrameRecorder& recorder);
  ~CaptureWriter();
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;

  // Creates the directory and starts the writer thread.
  [[nodiscard]] Error start();
  void stop();

  // A fault at `fault_ns` (wall clock, ns since the Unix epoch). Never blocks
  // on I/O; joins a pending capture whose window holds the fault. Returns
  // the file the frames will be in (empty: none, the writer is stuck or the
  // hour's budget is used up).
  std::string request(std::string cause, std::string device, std::int64_t fault_ns);

  // Writes every pending capture whose window closed by `now_ns`; returns
  // what was written.
  std::vector<CaptureInfo> poll(std::int64_t now_ns);

  [[nodiscard]] std::vector<CaptureInfo> recent() const;  // newest last
  // The text of capture `name`, one recent() lists (nothing outside the
  // captures directory); a symbolic link or a file over kMaxServedBytes is
  // refused. Any thread; reads the disk.
  [[nodiscard]] Result<std::string> read(std::string_view name) const;
  static constexpr std::uint64_t kMaxServedBytes = 1ull << 30;
  [[nodiscard]] std::size_t pending() const;
  // Captures not made because the hour's budget was used up, since start.
  [[nodiscard]] std::uint64_t skipped_over_budget() const;
  [[nodiscard]] const CaptureOptions& options() const noexcept { return options_; }
  [[nodiscard]] const can::FrameRecorder& recorder() const noexcept { return recorder_; }

 private:
  struct Pending {
    CaptureInfo info;
    std::int64_t window_end_ns = 0;
  };
  void run();
  [[nodiscard]] Error write(CaptureInfo& info, std::int64_t window_end_ns);
  // Deletes the bus's oldest captures until they and `room` more bytes fit
  // in the cap.
  void enforce_cap(std::uint64_t room);
  // Writes the log and its sidecar, fsynced, under their final names.
  [[nodiscard]] Error write_files(const std::string& name, const std::string& text, const std::string& sidecar);
  // Names once each file of this bus's name that is not a regular file.
  void warn_strangers();
  // With the mutex held: may a new window open at `now_ns` (one capture
  // more this hour)? Counts and logs what the budget refuses.
  [[nodiscard]] bool take_budget_locked(std::int64_t now_ns);
  // With the mutex held: a new hour once the last one is over, its skips
  // logged in one line.
  void roll_budget_locked(std::int64_t now_ns);

  CaptureOptions options_;
  const can::FrameRecorder& recorder_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Pending> pending_;
  std::deque<CaptureInfo> recent_;
  std::vector<std::string> strangers_;  // the writer thread's: named in a warning already
  struct Budget {
    bool started = false;       // an hour is counted (from its first capture)
    std::int64_t hour_from_ns = 0;
    std::uint32_t made = 0;     // captures this hour
    std::uint32_t skipped = 0;  // refused this hour
    std::uint64_t skipped_total = 0;
  } budget_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace cobridge::bus
