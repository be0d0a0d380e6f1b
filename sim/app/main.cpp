// cobridge-sim: wires the command line, the signals and the Simulator.
#include "app/command_line.hpp"
#include "app/simulator.hpp"
#include "device/sim_device.hpp"
#include "sys/install_paths.hpp"
#include "sys/signals.hpp"

#include <sched.h>
#include <sys/prctl.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

int main(int argc, char** argv) {
  using namespace cobridge;
  const sim::CommandLineResult cl =
      sim::parse_command_line(argc, argv, &sim::find_model, sim::all_models(),
                              sys::installed_dir(sys::InstallDir::devices, sys::executable()),
                              COBRIDGE_SIM_SOURCE_DEVICES_DIR);
  if (const int code = cl.exit_code(); code >= 0) {
    std::fputs(cl.output().c_str(), code == 0 ? stdout : stderr);
    std::fputc('\n', code == 0 ? stdout : stderr);
    return code;
  }
  // Blocked before anything else so no signal interrupts start-up half way.
  sys::Signals signals;
  if (const Error& e = signals.error()) {
    std::fprintf(stderr, "cobridge-sim: %s\n", e.to_string().c_str());
    return 1;
  }
  // 1 ms event timers want wake-ups close to their deadline, not 50 us late.
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (cl.options.rt_priority > 0) {
    const sched_param p{cl.options.rt_priority};
    if (::sched_setscheduler(0, SCHED_FIFO, &p) != 0) {
      std::fprintf(stderr, "cobridge-sim: --rt-priority %d: %s (SCHED_FIFO needs CAP_SYS_NICE)\n",
                   cl.options.rt_priority, std::strerror(errno));
      return 1;
    }
  }

  sim::Simulator simulator(cl.options);
  if (const Error e = simulator.start()) {
    std::fprintf(stderr, "cobridge-sim: %s\n", e.to_string().c_str());
    return exit_code(e.kind);
  }
  return simulator.run(signals);
}
