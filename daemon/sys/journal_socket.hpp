// JournalSocket: systemd-journald's native protocol, written here rather than
// linked from libsystemd (systemd documents the protocol as stable for
// reimplementation: "Native Journal Protocol"); loading the library and its
// compression and crypto chain on every start costs more than these lines.
//
// One entry is one datagram to /run/systemd/journal/socket: each field
// "KEY=value\n", or, when the value holds a newline, "KEY\n", the value's
// length as 64-bit little endian, the value and "\n". An entry too large for
// a datagram travels as a sealed memfd passed with SCM_RIGHTS instead. No
// journald listening (the socket missing) is not an error: the entry is
// dropped, as sd_journal_sendv(3) does.
//
// Thread: one thread at a time (JournalSink calls it under spdlog's mutex).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace cobridge::sys {

// The datagram of one entry; fields are "KEY=value".
[[nodiscard]] std::string journal_datagram(const std::vector<std::string>& fields);

class JournalSocket {
 public:
  static constexpr std::string_view kPath = "/run/systemd/journal/socket";

  explicit JournalSocket(std::string path = std::string(kPath));
  ~JournalSocket();
  JournalSocket(const JournalSocket&) = delete;
  JournalSocket& operator=(const JournalSocket&) = delete;

  // Sends one entry; returns 0 or -errno.
  int send(const std::vector<std::string>& fields);

 private:
  int send_as_memfd(const std::string& datagram);
  std::string path_;
  int fd_ = -1;
};

}  // namespace cobridge::sys
