// PeerCredentials: who is at the other end of a local (Unix) socket, as the
// kernel says (SO_PEERCRED), and whether that user is in a group. The
// control socket logs every write with it and lets only the configured
// group write (issue 15, item 2).
//
// Thread: any; reads the user and group databases (getpwuid_r, getgrnam_r,
// getgrouplist): the main thread, never the hot path.
#pragma once

#include <sys/types.h>

#include <string>

namespace cobridge::gateway {

struct PeerCredentials {
  bool known = false;  // false: not a Unix socket, or the kernel would not say
  uid_t uid = 0;
  gid_t gid = 0;
  pid_t pid = 0;

  // "uid 1000 pid 4711" (or "unknown peer").
  [[nodiscard]] std::string to_string() const;
};

[[nodiscard]] PeerCredentials peer_credentials(int fd) noexcept;
// True when the peer's uid has `group` as its primary group or among its
// supplementary groups in the group database. False for an unknown group.
[[nodiscard]] bool peer_in_group(const PeerCredentials& peer, const std::string& group);

}  // namespace cobridge::gateway
