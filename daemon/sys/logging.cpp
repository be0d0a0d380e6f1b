#include "sys/logging.hpp"

#include "sys/journal_sink.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <mutex>
#include <string>

namespace cobridge::sys {
namespace {

std::mutex g_mutex;
spdlog::sink_ptr g_sink;
spdlog::level::level_enum g_level = spdlog::level::info;

spdlog::sink_ptr make_sink(LogTarget target) {
  if (target == LogTarget::automatic) target = stderr_is_journal() ? LogTarget::journal : LogTarget::console;
  if (target == LogTarget::journal) return std::make_shared<JournalSink>("cobridged");
  return std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
}

}  // namespace

void setup_logging(LogTarget target, spdlog::level::level_enum level) {
  std::lock_guard lock(g_mutex);
  g_sink = make_sink(target);
  g_level = level;
  spdlog::apply_all([](const std::shared_ptr<spdlog::logger>& l) {
    l->sinks().clear();
    l->sinks().push_back(g_sink);
    l->set_level(g_level);
  });
}

bool log_reaches_stderr() noexcept {
  bool journal = false;
  {
    std::lock_guard lock(g_mutex);
    journal = g_sink != nullptr && std::dynamic_pointer_cast<JournalSink>(g_sink) != nullptr;
  }
  return !journal || stderr_is_journal();
}

std::shared_ptr<spdlog::logger> logger(std::string_view module) {
  const std::string name(module);
  if (auto existing = spdlog::get(name)) return existing;
  std::lock_guard lock(g_mutex);
  if (auto existing = spdlog::get(name)) return existing;
  if (!g_sink) g_sink = make_sink(LogTarget::automatic);
  auto l = std::make_shared<spdlog::logger>(name, g_sink);
  l->set_level(g_level);
  spdlog::register_logger(l);
  return l;
}

bool set_level(std::string_view module, std::string_view level_name) {
  const std::string name(level_name);
  const auto level = spdlog::level::from_str(name);
  // from_str maps anything unknown to "off"; only accept "off" when asked for.
  if (level == spdlog::level::off && name != "off") return false;
  logger(module)->set_level(level);
  return true;
}

}  // namespace cobridge::sys
