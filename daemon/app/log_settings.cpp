#include "app/log_settings.hpp"

#include "sys/logging.hpp"

namespace cobridge::app {

void apply_logging(const config::LoggingSettings& logging, bool foreground) {
  sys::LogTarget target = sys::LogTarget::automatic;
  if (foreground || logging.target == config::LogTarget::console) target = sys::LogTarget::console;
  else if (logging.target == config::LogTarget::journal) target = sys::LogTarget::journal;
  sys::setup_logging(target, static_cast<spdlog::level::level_enum>(logging.level));
  for (const auto& [module, level] : logging.modules)
    sys::logger(module)->set_level(static_cast<spdlog::level::level_enum>(level));
}

}  // namespace cobridge::app
