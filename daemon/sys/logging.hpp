// Logging: one named spdlog logger per module ("can", "canopen", "device",
// "gateway", "sys", "dds", "modbus", "sim"), all sharing one sink: native
// journal entries (sys/journal_sink.hpp: priority, module, bus, node; no
// pattern of our own) when stderr is the journal's stream (systemd's
// StandardError=journal, JOURNAL_STREAM), the console otherwise. Every layer
// takes its logger from here, so no module logs past the chosen sink.
// Levels are set per module from the configuration.
//
// Never called on the hot path. Thread: setup() and set_level() from the main
// thread before/while workers run (spdlog loggers are thread-safe to use).
#pragma once

#include <spdlog/spdlog.h>

#include <memory>
#include <string_view>

namespace cobridge::sys {

enum class LogTarget { automatic, console, journal };

// Creates the module loggers. Idempotent; later calls change the target.
void setup_logging(LogTarget target = LogTarget::automatic,
                   spdlog::level::level_enum level = spdlog::level::info);

// The logger of a module; created on first use with the current sink.
std::shared_ptr<spdlog::logger> logger(std::string_view module);

// True when log lines reach what stderr reaches (the console sink, or the
// journal when stderr is the journal's stream): a message printed on stderr
// for an operator would then be the same failure a second time.
[[nodiscard]] bool log_reaches_stderr() noexcept;

// Returns false if `level_name` is not one of trace, debug, info, warn,
// error, critical, off.
bool set_level(std::string_view module, std::string_view level_name);

}  // namespace cobridge::sys
