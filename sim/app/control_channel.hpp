// ControlChannel: where cobridge-sim's control lines come from and where the
// replies go: stdin (replies on stdout) and, optionally, a Unix stream socket
// that any number of clients may connect to (replies on the same
// connection). Lines are handed to a handler that returns the reply line.
//
// The owner adds the channel's fds to its poll set (append_poll_fds) and
// calls service() with the poll result; nothing blocks except writing a reply
// to stdout. stdin reaching end-of-file is not a command: the channel stops
// watching it (tests run the simulator with stdin on /dev/null).
// Thread: the simulator's loop thread; off the per-frame path (allocates).
#pragma once

#include "base/error.hpp"

#include <poll.h>

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace cobridge::sim {

class ControlChannel {
 public:
  using Handler = std::function<std::string(std::string_view line)>;
  static constexpr std::size_t kMaxLineBytes = 4096;

  ControlChannel() = default;
  ~ControlChannel();
  ControlChannel(const ControlChannel&) = delete;
  ControlChannel& operator=(const ControlChannel&) = delete;

  // Listens at `path` (a stale socket file there is replaced). A failure has
  // the path as its where and the errno as its code.
  [[nodiscard]] Error listen(const std::filesystem::path& path);
  // Reads commands from `fd` and writes replies to `reply_fd`.
  void watch_input(int fd, int reply_fd) noexcept;

  void append_poll_fds(std::vector<pollfd>& fds);
  // `fds` is the array given to poll(); only the entries this channel added
  // (since the last append_poll_fds) are looked at.
  void service(const std::vector<pollfd>& fds, const Handler& handler);

  [[nodiscard]] std::size_t clients() const noexcept { return clients_.size(); }

 private:
  struct Client {
    int fd = -1;
    std::string pending;
  };
  void handle_lines(Client& c, const Handler& handler, int reply_fd);
  static bool write_all(int fd, std::string_view data) noexcept;

  int listen_fd_ = -1;
  std::filesystem::path path_;
  Client input_;
  int reply_fd_ = -1;
  std::vector<Client> clients_;
  std::size_t poll_base_ = 0;
  std::size_t poll_count_ = 0;
};

}  // namespace cobridge::sim
