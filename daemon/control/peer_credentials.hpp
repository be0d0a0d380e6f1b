// PeerCredentials: who is at the other end of a local (Unix) socket, as the
// kernel says (SO_PEERCRED, SO_PEERGROUPS), and whether that process is in a
// group. The control socket logs every write with it and lets only the
// configured group write.
//
// Group membership is the process's, as the kernel recorded it when the
// peer connected: its effective gid (SO_PEERCRED) and its supplementary
// groups (SO_PEERGROUPS). These are the credentials the kernel checked
// against the socket file's mode 0660, so "may connect" and "may write"
// follow one rule: a service given a group by systemd's
// SupplementaryGroups= (not listed in /etc/group) is a member, a process
// that dropped the group (setgroups, setpriv --groups) is not, and a user
// added to the group in /etc/group is one from the next login on, as for
// any file. The group database only turns the group's name into its gid.
//
// A peer the kernel cannot name (getsockopt fails, or a TCP connection,
// which carries no credentials) has no identity: not uid 0, in no group, and
// refused by every write check that asks for a user or group (never taken
// for root).
//
// Thread: any; peer_credentials() is two getsockopt calls, peer_in_group()
// and write_group_refusal() read the group database (getgrnam_r): the main
// thread, never the hot path.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace cobridge::control {

inline constexpr uid_t kNoUid = static_cast<uid_t>(-1);  // no user has it (setresuid's "unchanged")
inline constexpr gid_t kNoGid = static_cast<gid_t>(-1);

struct PeerCredentials {
  bool known = false;  // false: not a Unix socket, or the kernel would not say
  uid_t uid = kNoUid;  // never 0 (root) unless the kernel said so
  gid_t gid = kNoGid;  // effective gid at connect()
  pid_t pid = 0;
  // Supplementary groups at connect(); empty when the kernel would not say
  // (then only `gid` counts: a check fails closed).
  std::vector<gid_t> groups;

  // "uid 1000 pid 4711" (or "unknown peer").
  [[nodiscard]] std::string to_string() const;
};

[[nodiscard]] PeerCredentials peer_credentials(int fd);
// True when the group named `group` exists and is the peer's effective gid
// or one of its supplementary groups (as the kernel had them at connect()).
// False for an unknown peer or group.
[[nodiscard]] bool peer_in_group(const PeerCredentials& peer, const std::string& group);

// The control socket's write rule ([control] write_group; docs/operations.md
// "Access"): with a group set, the caller must be root, the daemon's own user
// (`daemon_uid`) or in the group; an empty group lets anyone who may connect
// (the socket file's mode) write. Returns why `peer` may not write, empty
// when it may; an unknown peer is refused whenever a group is set.
[[nodiscard]] std::string write_group_refusal(const PeerCredentials& peer, const std::string& write_group,
                                              uid_t daemon_uid);

}  // namespace cobridge::control
