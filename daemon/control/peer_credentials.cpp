#include "control/peer_credentials.hpp"

#include <grp.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>

namespace cobridge::control {
namespace {

// SO_PEERGROUPS (Linux 4.13): the peer's supplementary groups at connect().
// ERANGE tells the size needed; a process has at most NGROUPS_MAX (65536).
std::vector<gid_t> peer_groups(int fd) {
  std::vector<gid_t> groups(64);
  for (int attempt = 0; attempt < 2; ++attempt) {
    socklen_t len = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups.data(), &len) == 0) {
      groups.resize(len / sizeof(gid_t));
      return groups;
    }
    if (errno != ERANGE) break;
    groups.resize(len / sizeof(gid_t) + 1);
  }
  return {};
}

}  // namespace

std::string PeerCredentials::to_string() const {
  if (!known) return "unknown peer";
  return "uid " + std::to_string(uid) + " pid " + std::to_string(pid);
}

PeerCredentials peer_credentials(int fd) {
  PeerCredentials p;
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || len != sizeof cred) return p;
  // A socket without credentials (TCP) answers uid and gid -1, pid 0.
  if (cred.uid == kNoUid || cred.gid == kNoGid) return p;
  p.known = true;
  p.uid = cred.uid;
  p.gid = cred.gid;
  p.pid = cred.pid;
  p.groups = peer_groups(fd);
  return p;
}

bool peer_in_group(const PeerCredentials& peer, const std::string& group_name) {
  if (!peer.known) return false;
  std::vector<char> buf(16384);
  struct group grp {};
  struct group* gr = nullptr;
  int rc = 0;
  while ((rc = ::getgrnam_r(group_name.c_str(), &grp, buf.data(), buf.size(), &gr)) == ERANGE && buf.size() < (1u << 24))
    buf.resize(buf.size() * 4);
  if (rc != 0 || gr == nullptr) return false;
  const gid_t wanted = gr->gr_gid;
  return peer.gid == wanted || std::find(peer.groups.begin(), peer.groups.end(), wanted) != peer.groups.end();
}

std::string write_group_refusal(const PeerCredentials& peer, const std::string& write_group,
                                uid_t daemon_uid) {
  if (write_group.empty()) return {};
  const std::string rule = "the write group \"" + write_group + "\" ([control] write_group)";
  if (!peer.known)
    return "the caller is unknown (the kernel gave no credentials for the connection), so it cannot be checked "
           "against " + rule;
  if (peer.uid == 0 || peer.uid == daemon_uid || peer_in_group(peer, write_group)) return {};
  return "uid " + std::to_string(peer.uid) + " is not in " + rule;
}

}  // namespace cobridge::control
