// Signals: SIGTERM/SIGINT (stop) and SIGHUP (reload) as a pollable fd.
//
// The signals are blocked in every thread and read through a signalfd by the
// main loop, so no handler runs asynchronously and nothing async-unsafe can
// happen in one. Construct it in main() before starting any thread (threads
// inherit the blocked mask).
// Thread: the main loop only.
#pragma once

#include "base/error.hpp"

namespace cobridge::sys {

enum class SignalAction { none, stop, reload };

class Signals {
 public:
  Signals();
  ~Signals();
  Signals(const Signals&) = delete;
  Signals& operator=(const Signals&) = delete;

  // Why the signals could not be taken over (where "signals", the errno as
  // the code); kOk when they were.
  [[nodiscard]] const Error& error() const noexcept { return error_; }
  [[nodiscard]] int fd() const noexcept { return fd_; }
  // Reads every pending signal; stop wins over reload.
  SignalAction take();

 private:
  int fd_ = -1;
  Error error_;
};

}  // namespace cobridge::sys
