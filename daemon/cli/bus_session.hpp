// BusSession: drives non-blocking protocol components (SDO client, LSS
// master, ...) over one SocketCAN channel until they finish, for the
// command-line tool, which wants "do this and tell me" semantics.
//
// It polls the channel fd with the earliest deadline any component asked
// for, feeds every received frame to the caller's handler, and stops when
// the caller's predicate says done or the time budget is spent.
// Thread: one thread (the CLI's main thread).
#pragma once

#include "base/result.hpp"
#include "can/socketcan_channel.hpp"
#include "canopen/clock.hpp"

#include <chrono>
#include <functional>
#include <memory>
#include <string>

namespace cobridge::cli {

using canopen::TimePoint;

class BusSession {
 public:
  // Opens the interface, or says why not (kUnavailable, or kInvalidArgument
  // for an impossible name; where = iface).
  [[nodiscard]] static Result<std::unique_ptr<BusSession>> open(const std::string& iface);

  [[nodiscard]] can::SocketCanChannel& channel() noexcept { return channel_; }

  using FrameHandler = std::function<void(const can::Frame&, TimePoint)>;
  using Process = std::function<TimePoint(TimePoint)>;  // returns next deadline
  using Done = std::function<bool()>;

  // Runs until done() or `budget` elapsed; returns done().
  bool run(const FrameHandler& on_frame, const Process& process, const Done& done,
           std::chrono::milliseconds budget);

  // Receives for `duration`, handing every frame to on_frame.
  void listen(const FrameHandler& on_frame, std::chrono::milliseconds duration);

 private:
  explicit BusSession(const std::string& iface);
  can::SocketCanChannel channel_;
};

}  // namespace cobridge::cli
