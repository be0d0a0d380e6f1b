// ConnectionLoan: a client's connection lent by the main thread to the bus's
// control thread between two commands, so that the bus thread reads the
// client's next request itself (an SDO read through the daemon
// adds <= 1 ms). Without it every request takes two hand-overs before the
// CAN frame goes out (client -> main thread -> bus thread), each a wake-up
// that UML's one CPU makes expensive; with it, one (client -> bus thread),
// as for a client on the CAN socket itself.
//
// The main thread lends a connection with a read command only while nothing
// else is owed to it or buffered from it, so bytes are read by one thread
// at a time, in order. The bus thread keeps it after the command when the
// client got its whole answer (RemoteResult::kept) and gives it back
// (RemoteResult::returned) on anything it does not run alone: a request it
// does not take (a write, another bus, status: everything but a read on
// this bus; access checks and the log of writes stay with the main thread),
// a partial or more than one line, the client's end, an answer the socket
// did not take, `idle_timeout` without a request, or the bus stopping.
//
// LoanedConnections is the bus thread's list of the connections it holds
// between commands: their descriptors for its poll, the requests they send.
//
// Threads: ConnectionLoan is built by the main thread and used only by the
// bus thread while lent (`take` runs there: it must not touch the server's
// state). LoanedConnections: the bus's control thread, through
// RemoteExecutor. Never on the hot path (once per client request).
#pragma once

#include "canopen/clock.hpp"
#include "bus/remote/poll_slot.hpp"
#include "bus/remote/direct_answer.hpp"
#include "bus/remote/remote_command.hpp"
#include "bus/remote/remote_replies.hpp"

#include <poll.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

namespace cobridge::gateway {

struct ConnectionLoan {
  std::shared_ptr<DirectAnswer> connection;
  // The command a request line (without its LF or CR LF) asks, with its answer
  // armed on `connection`; nullopt: not one the bus thread runs alone.
  std::function<std::optional<RemoteCommand>(std::string_view line, DirectAnswer& connection)> take;
  std::size_t max_line = 256;
  std::chrono::milliseconds idle_timeout{2000};
};

class LoanedConnections {
 public:
  LoanedConnections() = default;
  ~LoanedConnections();
  LoanedConnections(const LoanedConnections&) = delete;
  LoanedConnections& operator=(const LoanedConnections&) = delete;

  // A finished command's connection stays: `tag` is the submitter's, for
  // the results that give it back; `to` where they go.
  void keep(std::shared_ptr<ConnectionLoan> loan, std::uint64_t tag, std::shared_ptr<RemoteReplies> to);

  void add_poll_fds(std::vector<pollfd>& fds);
  void note_ready(const std::vector<pollfd>& fds);

  // A request taken from a connection: the command (its loan and tag set),
  // and where its connection goes back to.
  using Run = std::function<void(RemoteCommand command, std::shared_ptr<RemoteReplies> to)>;
  // Reads the ready connections: a request the loan takes goes to `run`
  // (the connection is the command's until it is kept again); anything
  // else, and an idle connection, goes back. Returns the next idle deadline.
  canopen::TimePoint process(canopen::TimePoint now, const Run& run);
  // Every connection goes back (the bus stops).
  void return_all();
  [[nodiscard]] std::size_t size() const noexcept { return held_.size(); }

 private:
  struct Held {
    std::shared_ptr<ConnectionLoan> loan;
    std::uint64_t tag = 0;
    std::shared_ptr<RemoteReplies> to;
    canopen::TimePoint idle_at{};  // set on the first turn after keep()
    PollSlot slot;
  };
  // false: the connection went back (or is the new command's).
  bool read_request(Held& h, const Run& run);

  std::vector<Held> held_;
};

// Gives a connection back to its main thread (RemoteResult::returned).
void give_back(std::uint64_t tag, RemoteReplies& to, RemoteResult result);

// Main thread: what a result of its client's command says of the loan, for
// a server whose clients have `lent`, `wake_asked`, `pending`, `in` and
// `peer_closed`. True: kept, the bus thread reads the client now (the
// server leaves its socket alone). False: the client is the server's again,
// with what the bus thread read of it (returned) as its input.
template <typename Client>
bool take_loan_news(Client& c, RemoteResult& r) {
  if (r.kept) {
    c.lent = true;
    c.wake_asked = false;
    c.pending = {};
    return true;
  }
  c.lent = false;
  if (r.returned) {
    c.in += r.input;
    c.peer_closed = c.peer_closed || r.peer_closed;
  }
  return false;
}

}  // namespace cobridge::gateway
