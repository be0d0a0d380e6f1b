#include "cli/bus_session.hpp"

#include <poll.h>

#include <algorithm>
#include <array>

namespace cobridge::cli {

BusSession::BusSession(const std::string& iface) : channel_(can::SocketCanConfig{.interface = iface}) {}

Result<std::unique_ptr<BusSession>> BusSession::open(const std::string& iface) {
  std::unique_ptr<BusSession> s(new BusSession(iface));
  if (Error e = s->channel_.open()) return e;
  if (!s->channel_.is_open()) return Error(Errc::kUnavailable, "interface is down", iface);
  return s;
}

bool BusSession::run(const FrameHandler& on_frame, const Process& process, const Done& done,
                     std::chrono::milliseconds budget) {
  const TimePoint end = canopen::Clock::now() + budget;
  std::array<can::Frame, 64> frames;
  for (;;) {
    TimePoint now = canopen::Clock::now();
    TimePoint next = process(now);
    if (done()) return true;
    if (now >= end) return false;
    next = std::min(next, end);
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count();
    pollfd pfd{channel_.fd(), POLLIN, 0};
    // +1 rounds up so we never wake just before a deadline and spin.
    ::poll(&pfd, 1, static_cast<int>(std::clamp<long long>(wait + 1, 0, 1000)));
    const std::size_t n = channel_.receive(frames);
    now = canopen::Clock::now();
    for (std::size_t i = 0; i < n; ++i) on_frame(frames[i], now);
    (void)channel_.process(now);
  }
}

void BusSession::listen(const FrameHandler& on_frame, std::chrono::milliseconds duration) {
  run(on_frame, [](TimePoint) { return canopen::kNever; }, [] { return false; }, duration);
}

}  // namespace cobridge::cli
