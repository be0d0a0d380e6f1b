#include "sys/journal_sink.hpp"

#include "sys/journal_socket.hpp"

#include <sys/stat.h>
#include <syslog.h>
#include <unistd.h>

#include <cctype>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace cobridge::sys {
namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::string_view leading_number(std::string_view s) {
  std::size_t n = 0;
  while (n < s.size() && n < 3 && is_digit(s[n])) ++n;
  if (n == 0 || (n < s.size() && is_digit(s[n]))) return {};
  return s.substr(0, n);
}

}  // namespace

int journal_priority(spdlog::level::level_enum level) noexcept {
  switch (level) {
    case spdlog::level::trace:
    case spdlog::level::debug: return LOG_DEBUG;
    case spdlog::level::info: return LOG_INFO;
    case spdlog::level::warn: return LOG_WARNING;
    case spdlog::level::err: return LOG_ERR;
    case spdlog::level::critical: return LOG_CRIT;
    default: return LOG_INFO;
  }
}

std::string_view journal_bus(std::string_view message) noexcept {
  constexpr std::string_view kPrefix = "bus ";
  if (message.substr(0, kPrefix.size()) != kPrefix) return {};
  const std::string_view rest = message.substr(kPrefix.size());
  const std::size_t colon = rest.find(':');
  if (colon == 0 || colon == std::string_view::npos) return {};
  const std::string_view name = rest.substr(0, colon);
  // A bus name is an identifier (config: A-Z a-z 0-9 _ - .): anything else is prose.
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '.')) return {};
  return name;
}

std::string_view journal_node(std::string_view message) noexcept {
  for (std::string_view key : {std::string_view("(node "), std::string_view("at node ")}) {
    const std::size_t at = message.find(key);
    if (at == std::string_view::npos) continue;
    const std::string_view n = leading_number(message.substr(at + key.size()));
    if (!n.empty()) return n;
  }
  return {};
}

std::vector<std::string> journal_fields(std::string_view identifier, std::string_view module,
                                        spdlog::level::level_enum level, std::string_view message) {
  std::vector<std::string> f;
  f.reserve(6);
  f.push_back("MESSAGE=" + std::string(message));
  f.push_back("PRIORITY=" + std::to_string(journal_priority(level)));
  f.push_back("SYSLOG_IDENTIFIER=" + std::string(identifier));
  if (!module.empty()) f.push_back("COBRIDGE_MODULE=" + std::string(module));
  if (const auto bus = journal_bus(message); !bus.empty()) f.push_back("BUS=" + std::string(bus));
  if (const auto node = journal_node(message); !node.empty()) f.push_back("NODE=" + std::string(node));
  return f;
}

JournalSink::JournalSink(std::string identifier, Send send) : identifier_(std::move(identifier)), send_(std::move(send)) {
  if (!send_) {
    send_ = [socket = std::make_shared<JournalSocket>()](const std::vector<std::string>& fields) {
      return socket->send(fields);
    };
  }
}

void JournalSink::sink_it_(const spdlog::details::log_msg& msg) {
  std::string_view text(msg.payload.data(), msg.payload.size());
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
  const std::string_view module(msg.logger_name.data(), msg.logger_name.size());
  // A journal that cannot be reached loses the line; there is nowhere better to say so.
  (void)send_(journal_fields(identifier_, module, msg.level, text));
}

bool stderr_is_journal() noexcept {
  const char* env = std::getenv("JOURNAL_STREAM");
  if (env == nullptr) return false;
  const std::string_view s(env);
  const std::size_t colon = s.find(':');
  if (colon == std::string_view::npos) return false;
  unsigned long long dev = 0;
  unsigned long long ino = 0;
  const auto r1 = std::from_chars(s.data(), s.data() + colon, dev);
  const auto r2 = std::from_chars(s.data() + colon + 1, s.data() + s.size(), ino);
  if (r1.ec != std::errc() || r1.ptr != s.data() + colon || r2.ec != std::errc() || r2.ptr != s.data() + s.size())
    return false;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) != 0) return false;
  return static_cast<unsigned long long>(st.st_dev) == dev && static_cast<unsigned long long>(st.st_ino) == ino;
}

}  // namespace cobridge::sys
