#include "gateway/remote/peer_credentials.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>

#include <vector>

namespace cobridge::gateway {

std::string PeerCredentials::to_string() const {
  if (!known) return "unknown peer";
  return "uid " + std::to_string(uid) + " pid " + std::to_string(pid);
}

PeerCredentials peer_credentials(int fd) noexcept {
  PeerCredentials p;
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || len != sizeof cred) return p;
  p.known = true;
  p.uid = cred.uid;
  p.gid = cred.gid;
  p.pid = cred.pid;
  return p;
}

bool peer_in_group(const PeerCredentials& peer, const std::string& group_name) {
  if (!peer.known) return false;
  std::vector<char> buf(16384);
  struct group grp {};
  struct group* gr = nullptr;
  if (::getgrnam_r(group_name.c_str(), &grp, buf.data(), buf.size(), &gr) != 0 || gr == nullptr) return false;
  const gid_t wanted = gr->gr_gid;
  if (peer.gid == wanted) return true;
  struct passwd pw {};
  struct passwd* pwp = nullptr;
  std::vector<char> pbuf(16384);
  if (::getpwuid_r(peer.uid, &pw, pbuf.data(), pbuf.size(), &pwp) != 0 || pwp == nullptr) return false;
  int n = 64;
  std::vector<gid_t> groups(static_cast<std::size_t>(n));
  if (::getgrouplist(pwp->pw_name, pwp->pw_gid, groups.data(), &n) < 0) {
    groups.resize(static_cast<std::size_t>(n));
    if (::getgrouplist(pwp->pw_name, pwp->pw_gid, groups.data(), &n) < 0) return false;
  }
  for (int i = 0; i < n; ++i) {
    if (groups[static_cast<std::size_t>(i)] == wanted) return true;
  }
  return false;
}

}  // namespace cobridge::gateway
