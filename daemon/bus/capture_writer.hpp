// CaptureWriter: writes the flight recorder's window around a fault of one
// bus to the state directory as a candump log, so that `canplayer` and log
// viewers replay it.
//
// A fault is requested with its wall-clock time; once `after` has passed
// since it, the writer takes the recorder's frames of [fault - before,
// fault + after] and writes <dir>/<bus>-<UTC time>-<cause>.log, one line per
// frame in `candump -l` form, "(SECONDS.MICROSECONDS) IFACE ID#DATA", with a
// sidecar <name>.json (bus, causes, devices, fault time, frames, bytes).
// candump logs have no comment lines, hence the sidecar. A fault inside the
// window of a capture still pending joins it (one file, every cause in the
// sidecar), so a storm of faults makes one file per window, not one per
// fault. Before each write the bus's oldest captures are deleted until its
// captures (logs and sidecars) and the new one fit in `cap_bytes`.
//
// Threads: request(), recent() and pending() from any thread (a mutex, held
// only to copy or append); start()/stop() from the owner; the writer thread
// does the snapshot and the file I/O, never the caller. poll() is the
// writer thread's step, public for tests that run it without the thread.
#pragma once

#include "base/error.hpp"
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
#include <vector>

namespace cobridge::gateway {

struct CaptureOptions {
  std::filesystem::path dir;   // <state_dir>/captures
  std::string bus;             // the bus's name, the file names' prefix
  std::string interface;       // written in every line (canplayer's source interface)
  std::chrono::nanoseconds before{std::chrono::seconds(10)};
  std::chrono::nanoseconds after{std::chrono::seconds(2)};
  std::uint64_t cap_bytes = 64ull << 20;  // this bus's captures on disk, at most
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
  std::uint64_t bytes = 0;           // the .log file's size
};

// "(1700000000.123456) vcan0 701#00": one candump -l line, newline included.
// Standard identifiers as 3 hex digits, extended (and error frames, with the
// CAN_ERR_FLAG bit) as 8; RTR frames as "ID#R".
[[nodiscard]] std::string candump_line(const can::Frame& frame, std::string_view interface);

// A capture of an earlier run as its file name tells it: the fault's time
// and its first cause ("heartbeat-lost" -> "heartbeat lost"); `prefix` is the
// length of "<bus>-". A name of another form gives the name only.
[[nodiscard]] CaptureInfo capture_from_name(const std::string& name, std::size_t prefix);

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
  // the file the frames will be in (empty: none, the writer is stuck).
  std::string request(std::string cause, std::string device, std::int64_t fault_ns);

  // Writes every pending capture whose window closed by `now_ns`; returns
  // what was written.
  std::vector<CaptureInfo> poll(std::int64_t now_ns);

  [[nodiscard]] std::vector<CaptureInfo> recent() const;  // newest last
  [[nodiscard]] std::size_t pending() const;
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

  CaptureOptions options_;
  const can::FrameRecorder& recorder_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Pending> pending_;
  std::deque<CaptureInfo> recent_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace cobridge::gateway
