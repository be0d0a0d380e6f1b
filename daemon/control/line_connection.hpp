// LineConnection: one client of a line-protocol server on the daemon's main
// loop (the control socket, the CiA 309-3 gateway): its non-blocking socket,
// the request bytes not yet a whole line, the answer not yet sent, and its
// place in the poll set. The two servers differ in what a line means, not in
// how bytes come and go, so that part is written once, here.
//
// Bounded: at most one line plus one byte (to see that it is too long) is
// buffered per client, whatever the client sends.
//
// Thread: the main loop, through the server that owns the connection.
#pragma once

#include "control/poll_slot.hpp"

#include <poll.h>

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::control {

struct LineConnection {
  int fd = -1;
  std::string in;            // received, not yet taken as a request
  std::string out;           // the answer not yet sent
  std::size_t out_done = 0;  // bytes of `out` already sent
  bool peer_closed = false;  // end of input (or a receive error)
  bool skipping = false;     // dropping the rest of an overlong line up to its newline
  PollSlot slot;

  [[nodiscard]] bool has_line() const noexcept { return in.find('\n') != std::string::npos; }
  [[nodiscard]] bool writing() const noexcept { return out_done < out.size(); }
  // The first whole line (has_line()) taken out of `in`, without its line end.
  [[nodiscard]] std::string take_line();
  // Receives without blocking until a whole line or more than `max_line`
  // bytes are buffered, or the socket is drained; sets peer_closed at its end.
  void read(std::size_t max_line);
  // Sends what the socket takes of `out`; when all of it is out, clears it.
  // False when the client is gone (an error other than EAGAIN / EINTR).
  [[nodiscard]] bool flush();
};

// A request line without its end: the LF and a CR before it, so that a line
// ended CR LF (CiA 309-3 clients, telnet) means what one ended LF does.
[[nodiscard]] std::string_view line_body(std::string_view line) noexcept;

// Accepts one waiting connection (non-blocking, close-on-exec). -1 when none
// waits or accept failed (a failure other than "none waiting" is logged,
// naming `server`). `peer` receives a TCP peer's address when not null.
[[nodiscard]] int accept_connection(int listen_fd, const char* server, void* peer = nullptr, unsigned* peer_len = nullptr);
// Tells a connection beyond the limit why (best effort: a fresh socket takes
// one short line) and closes it.
void refuse_connection(int fd, std::string_view line);

}  // namespace cobridge::control
