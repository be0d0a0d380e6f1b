#include "app/simulator.hpp"

#include "app/control_command.hpp"
#include "canopen/nmt.hpp"
#include "sys/signals.hpp"
#include "families/family_traits.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace cobridge::sim {

namespace {

std::int64_t realtime_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::string_view variant_of(const DeviceSpec& spec) {
  if (!families::traits(spec.model->family).channel_count_in_eds) return {};  // J§1.3.2
  return spec.channels == 2 ? "2ch" : "1ch";
}

std::string node_text(std::uint8_t node) {
  return node == 0xFF ? std::string("unconfigured") : std::to_string(node);
}

}  // namespace

Simulator::Simulator(SimOptions options) : options_(std::move(options)) {}

Simulator::~Simulator() {
  // Devices first: their truth sinks point at truth_.
  buses_.clear();
  truth_.flush();
}

Error Simulator::open_buses() {
  for (const BusOptions& b : options_.buses) {
    auto bus = std::make_unique<SimulatedBus>(b.iface);
    auto last_sent_ns = std::make_shared<std::int64_t>(0);  // this bus's last truth stamp
    if (const Error err = bus->open()) return Error(Errc::kFailed, err.message, "--iface '" + b.iface + "'", err.code);
    for (const DeviceSpec& spec : b.devices) {
      const device::DeviceDescription* desc =
          catalog_.select(spec.model->vendor, spec.model->product, std::nullopt, variant_of(spec));
      if (desc == nullptr)
        return Error(Errc::kInvalidArgument,
                     "no description in " + options_.devices_dir.string() + " for its vendor/product" +
                         (variant_of(spec).empty() ? "" : " and variant " + std::string(variant_of(spec))),
                     "device " + std::string(spec.model->name) + " (serial " + std::to_string(spec.serial) + ")");
      SimulatedBus* raw = bus.get();
      auto dev = std::make_unique<SimDevice>(spec, *desc, raw->sink_for(raw->size()), options_.state_dir);
      if (truth_.is_open()) {
        dev->set_truth_sink([this, raw, last_sent_ns](const TruthRecord& r) {
          // The device calls this right after the frame went to the socket:
          // CLOCK_REALTIME read here is the send time, comparable with the
          // SO_TIMESTAMPNS receive time of a reader on the same host. A
          // merged LSS answer left with the frame already sent and takes its
          // time: one clock read per frame on the wire (a system call under
          // UML), not 32 per Fastscan step.
          TruthRecord copy = r;
          if (copy.frame.timestamp_ns == 0)
            copy.frame.timestamp_ns = raw->last_send_merged() ? *last_sent_ns : realtime_ns();
          *last_sent_ns = copy.frame.timestamp_ns;
          truth_.write(raw->iface(), copy, now_);
        });
      }
      raw->add_device(std::move(dev));
    }
    buses_.push_back(std::move(bus));
  }
  return {};
}

Error Simulator::start() {
  const auto errors = catalog_.load_directory(options_.devices_dir);
  if (catalog_.size() == 0) {
    std::string msg = "no device description could be loaded from " + options_.devices_dir.string();
    if (!errors.empty()) msg += ": " + errors.front().message;
    return Error(Errc::kInvalidArgument, msg);
  }
  if (!options_.state_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options_.state_dir, ec);
    if (ec) return Error(Errc::kInvalidArgument, ec.message(), "--state-dir '" + options_.state_dir.string() + "'", ec);
  }
  if (!options_.truth_file.empty()) {
    if (const Error e = truth_.open(options_.truth_file.c_str()))
      return Error(Errc::kInvalidArgument, e.message, "--truth '" + options_.truth_file.string() + "'", e.code);
  }
  if (!options_.control_path.empty()) {
    if (const Error e = control_.listen(options_.control_path))
      return Error(Errc::kInvalidArgument, e.message, "--control '" + options_.control_path.string() + "'", e.code);
  }
  control_.watch_input(STDIN_FILENO, STDOUT_FILENO);

  if (Error e = open_buses()) return e;
  const canopen::TimePoint now = canopen::Clock::now();
  now_ = now;
  for (auto& bus : buses_) {
    for (std::size_t i = 0; i < bus->size(); ++i) {
      SimDevice& d = bus->device(i);
      if (const Error e = d.power_on(now))
        return Error(Errc::kInvalidArgument, "does not power on: " + e.to_string(),
                     "device " + std::string(d.spec().model->name) + " (serial " + std::to_string(d.spec().serial) +
                         ") on " + bus->iface(),
                     e.code);
      bus->deliver_local(now);
    }
  }
  return {};
}

std::optional<Simulator::Located> Simulator::find_device(std::uint32_t serial) {
  for (auto& bus : buses_)
    for (std::size_t i = 0; i < bus->size(); ++i)
      if (bus->device(i).spec().serial == serial) return Located{bus.get(), i};
  return std::nullopt;
}

SimulatedBus* Simulator::find_bus(std::string_view iface) {
  for (auto& bus : buses_)
    if (bus->iface() == iface) return bus.get();
  return nullptr;
}

std::string Simulator::list() const {
  std::size_t count = 0;
  std::string items;
  for (const auto& bus : buses_) {
    for (std::size_t i = 0; i < bus->size(); ++i) {
      SimDevice& d = bus->device(i);
      ++count;
      items += ' ';
      items += std::to_string(d.spec().serial) + ':' + std::string(d.spec().model->name) + ':' + bus->iface() + ':' +
               node_text(d.node_id()) + ':';
      items += d.powered() ? std::string(canopen::to_string(d.nmt_state())) : std::string("off");
      if (bus->silent(i)) items += ",silent";
    }
  }
  return "ok " + std::to_string(count) + items;
}

std::string Simulator::stats() const {
  std::string s = "ok turns=" + std::to_string(loop_.turns) + " timed_wakes=" + std::to_string(loop_.timed_wakes) +
                  " late_over_1ms=" + std::to_string(loop_.late_over_1ms) +
                  " max_late_us=" + std::to_string(loop_.max_late_ns / 1000) + " mean_late_us=" +
                  std::to_string(loop_.timed_wakes == 0 ? 0 : loop_.late_sum_ns / loop_.timed_wakes / 1000) +
                  " truth_lines=" + std::to_string(truth_.lines()) +
                  " busy_over_1ms=" + std::to_string(loop_.busy_over_1ms) +
                  " max_busy_us=" + std::to_string(loop_.max_busy_ns / 1000);
  for (const auto& bus : buses_) {
    const BusStats& b = bus->stats();
    std::uint64_t late = 0;
    for (std::size_t i = 0; i < bus->size(); ++i) late += bus->device(i).late_lss_answers();
    const can::ChannelStats c = bus->channel().stats();
    s += " " + bus->iface() + ":sent=" + std::to_string(b.device_frames) + ",refused=" +
         std::to_string(b.device_refused) + ",received=" + std::to_string(b.received) + ",local=" +
         std::to_string(b.local_deliveries) + ",local_overflow=" + std::to_string(b.local_overflow) +
         ",injected=" + std::to_string(b.injected) + ",lss_merged=" + std::to_string(b.lss_merged) +
         ",lss_late=" + std::to_string(late) + ",rx_overflow=" + std::to_string(c.rx_overflow_drops);
  }
  return s;
}

std::string Simulator::execute(std::string_view line) {
  const ControlParse p = parse_control_command(line);
  if (!p.command) return "error " + p.error;
  const ControlCommand& c = *p.command;
  const canopen::TimePoint now = canopen::Clock::now();
  now_ = now;

  switch (c.verb) {
    case ControlVerb::list: return list();
    case ControlVerb::stats: return stats();
    case ControlVerb::help: {
      std::string h(control_help());
      std::replace(h.begin(), h.end(), '\n', ' ');
      return "ok " + h;
    }
    case ControlVerb::quit:
      quit_ = true;
      return "ok quit";
    default: break;
  }

  if (c.verb == ControlVerb::flood || c.verb == ControlVerb::babble || c.verb == ControlVerb::bus_error)
    return execute_on_bus(c, now);
  return execute_on_device(c, now);
}

std::string Simulator::execute_on_bus(const ControlCommand& c, canopen::TimePoint now) {
  SimulatedBus* bus = find_bus(c.iface);
  if (bus == nullptr) return "error no simulated bus on interface '" + c.iface + "'";
  const auto d = std::chrono::milliseconds(c.duration_ms);
  if (c.verb == ControlVerb::flood) {
    bus->start_flood(now, d);
    return "ok flood " + c.iface + " " + std::to_string(c.duration_ms) + " ms";
  }
  if (c.verb == ControlVerb::babble) {
    bus->start_babble(c.cob_id, now, d);
    return "ok babble " + c.iface + " " + std::to_string(c.duration_ms) + " ms";
  }
  const bool sent = bus->send_error_frame(c.bus_error, now);
  if (!sent) return "error " + c.iface + ": the error frame was not accepted by the interface";
  return "ok bus-error " + c.iface + " " + std::string(to_string(c.bus_error));
}

std::string Simulator::execute_on_device(const ControlCommand& c, canopen::TimePoint now) {
  const auto loc = find_device(c.serial);
  if (!loc) return "error no device with serial " + std::to_string(c.serial);
  SimulatedBus& bus = *loc->bus;
  SimDevice& d = bus.device(loc->index);
  Error error;
  std::string what;
  switch (c.verb) {
    case ControlVerb::power_cycle:
      error = d.power_cycle(now);
      what = "power-cycle";
      break;
    case ControlVerb::power_off:
      d.power_off();
      what = "power-off";
      break;
    case ControlVerb::power_on:
      if (d.powered()) return "error device " + std::to_string(c.serial) + " is already powered";
      error = d.power_on(now);
      what = "power-on";
      break;
    case ControlVerb::silence:
      bus.set_silent(loc->index, c.on);
      what = c.on ? "silence on" : "silence off";
      break;
    case ControlVerb::reboot_on_sdo:
      d.reboot_on_sdo(c.count);
      what = "reboot-on-sdo";
      break;
    case ControlVerb::abort_sdo:
      d.abort_sdo(c.sdo_index, c.abort_code);
      what = "abort-sdo";
      break;
    case ControlVerb::ignore_sdo:
      d.ignore_sdo(c.sdo_index, c.count);
      what = "ignore-sdo";
      break;
    case ControlVerb::fault:
      if (!d.powered()) return "error device " + std::to_string(c.serial) + " is powered off";
      d.inject(c.fault, now);
      what = "fault " + std::string(to_string(c.fault));
      break;
    case ControlVerb::move:
      if (!d.powered()) return "error device " + std::to_string(c.serial) + " is powered off";
      d.move_by(c.turns);
      what = "move";
      break;
    default: return "error internal: unhandled command";
  }
  bus.deliver_local(now);
  if (error) return "error " + what + " " + std::to_string(c.serial) + ": " + error.to_string();
  return "ok " + what + " " + std::to_string(c.serial);
}

void Simulator::note_busy(canopen::TimePoint turn_start) noexcept {
  // The turn's own length, wake-up to the next wait: a request that arrives
  // meanwhile waits that long, whatever the kernel's wake-up adds.
  const auto busy = std::chrono::duration_cast<std::chrono::nanoseconds>(canopen::Clock::now() - turn_start).count();
  loop_.max_busy_ns = std::max<std::int64_t>(loop_.max_busy_ns, busy);
  if (busy > 1'000'000) ++loop_.busy_over_1ms;
}

namespace {

// The ppoll timeout until `deadline`, to the nanosecond; a deadline already
// past means "poll, do not wait", never a busy loop.
timespec* poll_timeout(canopen::TimePoint deadline, canopen::TimePoint now, timespec& ts) {
  const auto wait = std::max(canopen::Duration::zero(), deadline - now);
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count();
  ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return &ts;
}

// How late the kernel woke the loop for `deadline`: the limit of every timer
// the simulator runs.
void count_wake(LoopStats& loop, canopen::TimePoint deadline, canopen::TimePoint now) {
  const auto late = std::chrono::duration_cast<std::chrono::nanoseconds>(now - deadline).count();
  ++loop.timed_wakes;
  if (late > 0) loop.late_sum_ns += static_cast<std::uint64_t>(late);
  loop.max_late_ns = std::max<std::int64_t>(loop.max_late_ns, late);
  if (late > 1'000'000) ++loop.late_over_1ms;
}

}  // namespace

int Simulator::run(sys::Signals& signals) {
  std::vector<pollfd> fds;
  fds.reserve(16 + buses_.size());
  std::vector<int> bus_slot(buses_.size(), -1);  // index in fds, -1 = not polled
  std::fputs("ready\n", stdout);
  std::fflush(stdout);
  // One clock read per loop turn: under UML every clock_gettime is a real
  // system call, and the turn is short compared with the 1 ms cycle.
  canopen::TimePoint now = canopen::Clock::now();
  bool receive_all = true;
  while (!quit_) {
    ++loop_.turns;
    now_ = now;
    for (std::size_t i = 0; i < buses_.size(); ++i) {
      const int slot = bus_slot[i];
      if (receive_all || (slot >= 0 && (fds[static_cast<std::size_t>(slot)].revents & POLLIN) != 0))
        buses_[i]->receive(now);
    }
    receive_all = false;
    canopen::TimePoint deadline = canopen::kNever;
    for (auto& bus : buses_) deadline = std::min(deadline, bus->process(now));
    deadline = std::min(deadline, truth_.process(now));

    fds.clear();
    fds.push_back(pollfd{signals.fd(), POLLIN, 0});
    for (std::size_t i = 0; i < buses_.size(); ++i) {
      const int fd = buses_[i]->channel().fd();
      bus_slot[i] = fd >= 0 ? static_cast<int>(fds.size()) : -1;
      if (fd >= 0) fds.push_back(pollfd{fd, POLLIN, 0});
    }
    control_.append_poll_fds(fds);

    // The timeout from the earliest deadline.
    timespec ts{};
    const bool timed = deadline != canopen::kNever;
    timespec* tsp = timed ? poll_timeout(deadline, now, ts) : nullptr;
    note_busy(now);
    const canopen::TimePoint before = now;
    const int n = ::ppoll(fds.data(), static_cast<nfds_t>(fds.size()), tsp, nullptr);
    if (n < 0 && errno != EINTR) {
      std::perror("cobridge-sim: poll");
      return 1;
    }
    now = canopen::Clock::now();
    if (n == 0 && timed && deadline > before) count_wake(loop_, deadline, now);
    if (n > 0) {
      if ((fds[0].revents & POLLIN) != 0 && signals.take() == sys::SignalAction::stop) break;
      control_.service(fds, [this](std::string_view line) { return execute(line); });
    }
  }
  truth_.flush();
  return 0;
}

}  // namespace cobridge::sim
