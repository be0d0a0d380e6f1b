#include "bus/remote/connection_loan.hpp"

#include "bus/remote/line_connection.hpp"

#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <string>
#include <utility>

namespace cobridge::gateway {

void give_back(std::uint64_t tag, RemoteReplies& to, RemoteResult result) {
  result.tag = tag;
  result.returned = true;
  to.push(std::move(result));
}

LoanedConnections::~LoanedConnections() { return_all(); }

void LoanedConnections::keep(std::shared_ptr<ConnectionLoan> loan, std::uint64_t tag,
                             std::shared_ptr<RemoteReplies> to) {
  Held h;
  h.loan = std::move(loan);
  h.tag = tag;
  h.to = std::move(to);
  // Its next request is news only when poll says so (level-triggered: one
  // already there is seen by the next poll); no recv that finds nothing.
  h.slot.clear();
  held_.push_back(std::move(h));
}

void LoanedConnections::add_poll_fds(std::vector<pollfd>& fds) {
  for (auto& h : held_) h.slot.add(fds, h.loan->connection->fd(), POLLIN);
}

void LoanedConnections::note_ready(const std::vector<pollfd>& fds) {
  for (auto& h : held_) h.slot.note(fds);
}

canopen::TimePoint LoanedConnections::process(canopen::TimePoint now, const Run& run) {
  canopen::TimePoint next = canopen::kNever;
  for (auto it = held_.begin(); it != held_.end();) {
    Held& h = *it;
    if (h.idle_at == canopen::TimePoint{}) h.idle_at = now + h.loan->idle_timeout;
    bool stays = true;
    if (h.slot.take()) stays = read_request(h, run);
    if (stays && now >= h.idle_at) {
      RemoteResult r;
      r.idle = true;
      if (h.to) give_back(h.tag, *h.to, std::move(r));
      stays = false;
    }
    if (!stays) {
      it = held_.erase(it);
      continue;
    }
    next = std::min(next, h.idle_at);
    ++it;
  }
  return next;
}

bool LoanedConnections::read_request(Held& h, const Run& run) {
  std::string buf(h.loan->max_line + 1, '\0');
  ssize_t n = -1;
  do {
    n = ::recv(h.loan->connection->fd(), buf.data(), buf.size(), MSG_DONTWAIT);
  } while (n < 0 && errno == EINTR);
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;  // nothing after all
  RemoteResult back;
  if (n <= 0) {
    back.peer_closed = true;  // its end, or a receive error: the main thread closes it
  } else {
    buf.resize(static_cast<std::size_t>(n));
    // Exactly one whole line: the bus thread's to run, if the loan takes it.
    if (buf.back() == '\n' && buf.find('\n') == buf.size() - 1) {
      const std::string_view line = line_body(buf);
      if (auto cmd = h.loan->take(line, *h.loan->connection)) {
        cmd->tag = h.tag;
        cmd->direct = h.loan->connection;
        cmd->loan = std::move(h.loan);
        run(std::move(*cmd), std::move(h.to));
        return false;
      }
    }
    back.input = std::move(buf);
  }
  if (h.to) give_back(h.tag, *h.to, std::move(back));
  return false;
}

void LoanedConnections::return_all() {
  for (auto& h : held_) {
    if (h.to) give_back(h.tag, *h.to, RemoteResult{});
  }
  held_.clear();
}

}  // namespace cobridge::gateway
