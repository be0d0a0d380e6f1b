// Journal sink: spdlog records sent to systemd-journald as native entries
// (sys/journal_socket.hpp): PRIORITY= from the level, MESSAGE= the text alone (the
// journal stamps time and process itself, so no console pattern), the module
// in COBRIDGE_MODULE=, and BUS= / NODE= when the text names them ("bus line1:
// device x (node 10) ..." as the bus manager writes it). `journalctl -u
// cobridged -o verbose` shows the fields; `journalctl COBRIDGE_MODULE=can`,
// `journalctl BUS=line1 NODE=10` select by them.
//
// Thread: any (spdlog serialises calls into the sink with its mutex).
#pragma once

#include <spdlog/sinks/base_sink.h>

#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::sys {

// The syslog priority (LOG_DEBUG..LOG_CRIT) of a spdlog level.
[[nodiscard]] int journal_priority(spdlog::level::level_enum level) noexcept;

// BUS= of a message: NAME in a message that starts "bus NAME: "; empty otherwise.
[[nodiscard]] std::string_view journal_bus(std::string_view message) noexcept;
// NODE= of a message: the decimal N of the first "(node N" or "at node N"; empty otherwise.
[[nodiscard]] std::string_view journal_node(std::string_view message) noexcept;

// The journal fields ("KEY=value") of one record, in the order they are sent.
[[nodiscard]] std::vector<std::string> journal_fields(std::string_view identifier, std::string_view module,
                                                      spdlog::level::level_enum level, std::string_view message);

// Sends each record's journal_fields(); `send` is a JournalSocket to journald
// unless a test replaces it (it gets the fields and returns 0 or -errno).
class JournalSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  using Send = std::function<int(const std::vector<std::string>& fields)>;
  explicit JournalSink(std::string identifier, Send send = {});

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override;
  void flush_() override {}

 private:
  std::string identifier_;
  Send send_;
};

// True when stderr is the journal's stream (JOURNAL_STREAM names stderr's
// device:inode, as systemd sets it for StandardError=journal): the case for
// logging natively instead of writing text into that stream.
[[nodiscard]] bool stderr_is_journal() noexcept;

}  // namespace cobridge::sys
