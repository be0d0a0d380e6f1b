// DirectAnswer: a client's connection as the bus's control thread sees it,
// so that the thread that finishes a client's command writes the answer
// line to the client itself and the daemon's main thread is not on the
// answer's path (an SDO read through the daemon adds <= 1 ms; the
// main thread's wake-up to copy the answer was one of its hand-overs).
//
// One per connection of the control socket or the CiA 309-3 gateway. It
// holds its own duplicate of the socket, so a connection the main thread
// closes while a command runs never leaves the bus thread a descriptor
// number that another socket may reuse.
//
// The answer goes out directly only when that keeps the order and loses
// nothing: the server arms it for a command only while nothing else is
// owed to the client (its output buffer is empty) and writes nothing to
// the connection until it has learnt the command's result; the bus thread
// sends the whole line with one non-blocking send (MSG_DONTWAIT,
// MSG_NOSIGNAL). What the socket did not take (all of it on EAGAIN, the
// rest of a partial write, nothing on an error) travels back in the
// RemoteResult, and the main thread sends it as before.
//
// Threads: construct and shut() on the main thread (the server's); arm()
// on the main thread before it queues a command, or on the bus thread that
// holds the connection on loan (connection_loan.hpp) when it takes the
// client's next request itself; send() on the bus's control thread, through
// RemoteExecutor. arm() happens before the command is queued and the main
// thread reads the result after RemoteReplies handed it over (both take a
// mutex), so two threads never use the armed format at once. Destroyed on
// whichever releases it last. Never on the hot path (once per client command).
#pragma once

#include "bus/remote/remote_command.hpp"
#include "bus/remote/remote_replies.hpp"

#include <functional>
#include <string>

namespace cobridge::gateway {

class DirectAnswer {
 public:
  // Duplicates `fd` (close-on-exec); without a duplicate (EMFILE) every
  // answer takes the main thread's path.
  explicit DirectAnswer(int fd);
  ~DirectAnswer();
  DirectAnswer(const DirectAnswer&) = delete;
  DirectAnswer& operator=(const DirectAnswer&) = delete;

  // The answer line of the next command, newline included.
  using Format = std::function<std::string(const RemoteResult&)>;
  // Before queueing a command on this connection, only while its output
  // buffer is empty (see Threads).
  void arm(Format format);
  // Main thread, closing a connection whose command still runs or that is
  // on loan: the peer sees the end at once (not when the command ends),
  // send() fails and the bus thread holding it reads its end.
  void shut() const noexcept;
  // The duplicate (-1 without one): the bus thread polls and reads it while
  // it holds the connection on loan.
  [[nodiscard]] int fd() const noexcept { return fd_; }

  // Bus thread, when the armed command is done: formats its answer into
  // result.answer and sends what the socket takes now (result.answer_sent).
  // Disarms; nothing happens when not armed.
  void send(RemoteResult& result);

 private:
  int fd_ = -1;
  Format format_;
};

// How a finished command's result goes back (the bus's control thread, in
// RemoteExecutor): the client's answer first, from this thread, when the
// command carries an armed DirectAnswer (answer_client: true when the
// client has it whole); then the result to `to` (push_result), quietly (no
// wake-up of the main thread) when the client has its whole answer and the
// main thread holds no next request of it (hand_back_quietly).
// hand_back does it all.
[[nodiscard]] bool answer_client(RemoteCommand& command, RemoteResult& result);
[[nodiscard]] bool hand_back_quietly(const RemoteCommand& command, bool sent_whole);
void push_result(RemoteReplies& to, RemoteResult result, bool quietly);
void hand_back(RemoteCommand& command, RemoteResult result, RemoteReplies* to);

}  // namespace cobridge::gateway
