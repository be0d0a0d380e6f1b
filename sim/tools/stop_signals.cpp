#include "stop_signals.hpp"

#include <signal.h>
#include <sys/signalfd.h>

namespace cobridge::sim::tools {

int stop_signal_fd() noexcept {
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  ::sigprocmask(SIG_BLOCK, &stop, nullptr);
  return ::signalfd(-1, &stop, SFD_CLOEXEC);
}

}  // namespace cobridge::sim::tools
