// collect_results: how the control socket and the CiA 309-3 gateway take
// the results of their clients' commands. Results whose answer
// the bus thread sent whole come back quietly (RemoteReplies::push_quiet);
// a client whose next request arrived first waits for a wake-up
// (wake_asked), and while any does, one stays asked for: another client's
// quiet result must not use it up.
//
// Thread: the servers' owner (the daemon's main thread). Clients are any
// range of structs with `waiting_tag` and `wake_asked`; `deliver(drain)`
// takes the results (drain: fd() was readable).
#pragma once

#include "bus/remote/remote_replies.hpp"

#include <algorithm>

namespace cobridge::gateway {

template <typename Clients, typename Deliver>
void collect_results(const Clients& clients, RemoteReplies& replies, bool drain, Deliver deliver) {
  deliver(drain);
  const auto asked = [](const auto& c) { return c.waiting_tag != 0 && c.wake_asked; };
  while (std::any_of(clients.begin(), clients.end(), asked) && !replies.want_wake()) deliver(false);
}

}  // namespace cobridge::gateway
