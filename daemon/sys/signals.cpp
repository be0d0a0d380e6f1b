#include "sys/signals.hpp"

#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>

namespace cobridge::sys {

Signals::Signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGHUP);
  // pthread_sigmask returns its error number; signalfd sets errno.
  if (const int err = pthread_sigmask(SIG_BLOCK, &set, nullptr); err != 0) {
    const std::error_code ec(err, std::system_category());
    error_ = Error(Errc::kFailed, ec.message(), "signals", ec);
    return;
  }
  fd_ = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
  if (fd_ < 0) {
    const std::error_code ec(errno, std::system_category());
    error_ = Error(Errc::kFailed, ec.message(), "signals", ec);
  }
}

Signals::~Signals() {
  if (fd_ >= 0) ::close(fd_);
}

SignalAction Signals::take() {
  SignalAction action = SignalAction::none;
  signalfd_siginfo info{};
  while (fd_ >= 0 && ::read(fd_, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
    if (info.ssi_signo == SIGTERM || info.ssi_signo == SIGINT)
      action = SignalAction::stop;
    else if (info.ssi_signo == SIGHUP && action == SignalAction::none)
      action = SignalAction::reload;
  }
  return action;
}

}  // namespace cobridge::sys
