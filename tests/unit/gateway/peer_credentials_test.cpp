// PeerCredentials: the control socket's write rule (issue 15, item 2;
// docs/operations.md "Access") asks whether the caller is in
// [control] write_group. The answer must be the process's groups as the
// kernel recorded them at connect() (SO_PEERCRED gid, SO_PEERGROUPS), the
// same credentials the kernel checked against the socket file's mode, not
// the user's entry in the group database. Real Unix sockets; callers with
// other credentials are forked children that change their groups and user
// (needs root, as the machines and CI run).
#include "gateway/remote/peer_credentials.hpp"

#include <grp.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <string>
#include <vector>

using cobridge::gateway::peer_credentials;
using cobridge::gateway::peer_in_group;
using cobridge::gateway::PeerCredentials;

namespace {

gid_t gid_of(const char* name) {
  const group* g = ::getgrnam(name);
  return g != nullptr ? g->gr_gid : static_cast<gid_t>(-1);
}

// A listening socket in the abstract namespace (no file to clean up).
struct Listener {
  int fd = -1;
  sockaddr_un addr{};
  socklen_t len = 0;
  Listener() {
    fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    addr.sun_family = AF_UNIX;
    const std::string name = "cobridge-peer-test-" + std::to_string(::getpid());
    name.copy(addr.sun_path + 1, name.size());
    len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
    if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), len) != 0 || ::listen(fd, 1) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ~Listener() {
    if (fd >= 0) ::close(fd);
  }
};

// Forks a child that takes the given groups, gid and uid (in that order, as
// a service manager does), connects and waits for the parent to close;
// returns what the accepting end learns of it.
PeerCredentials connect_as(const std::vector<gid_t>& groups, gid_t gid, uid_t uid) {
  Listener l;
  if (l.fd < 0) return {};
  const pid_t child = ::fork();
  if (child == 0) {
    if (::setgroups(groups.size(), groups.data()) != 0 || ::setresgid(gid, gid, gid) != 0 ||
        ::setresuid(uid, uid, uid) != 0)
      ::_exit(2);
    const int c = ::socket(AF_UNIX, SOCK_STREAM, 0);
    if (::connect(c, reinterpret_cast<sockaddr*>(&l.addr), l.len) != 0) ::_exit(3);
    char b;
    (void)::read(c, &b, 1);  // until the parent has asked
    ::_exit(0);
  }
  PeerCredentials p;
  const int a = ::accept4(l.fd, nullptr, nullptr, SOCK_CLOEXEC);
  if (a >= 0) {
    p = peer_credentials(a);
    ::close(a);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  return p;
}

}  // namespace

TEST(PeerCredentials, TheKernelNamesTheCallerAndItsGroups) {
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
  const PeerCredentials p = peer_credentials(sv[0]);
  ::close(sv[0]);
  ::close(sv[1]);
  ASSERT_TRUE(p.known);
  EXPECT_EQ(p.uid, ::geteuid());
  EXPECT_EQ(p.gid, ::getegid());
  EXPECT_EQ(p.pid, ::getpid());
  std::vector<gid_t> mine(static_cast<std::size_t>(::getgroups(0, nullptr)));
  mine.resize(static_cast<std::size_t>(::getgroups(static_cast<int>(mine.size()), mine.data())));
  std::vector<gid_t> theirs = p.groups;
  std::sort(mine.begin(), mine.end());
  std::sort(theirs.begin(), theirs.end());
  EXPECT_EQ(theirs, mine);
  EXPECT_EQ(p.to_string(), "uid " + std::to_string(p.uid) + " pid " + std::to_string(p.pid));
}

TEST(PeerCredentials, NotASocketIsAnUnknownPeerInNoGroup) {
  const PeerCredentials p = peer_credentials(-1);
  EXPECT_FALSE(p.known);
  EXPECT_EQ(p.to_string(), "unknown peer");
  EXPECT_FALSE(peer_in_group(p, "root"));
}

// Like systemd's SupplementaryGroups=: user nobody's process carries group
// "users", which the group database does not give nobody. It may open a
// 0660 socket of that group, so it is a member for the write rule too.
TEST(PeerCredentials, ASupplementaryGroupOfTheProcessCountsThoughTheDatabaseOmitsIt) {
  ASSERT_EQ(::geteuid(), 0u) << "forks callers with other credentials: run as root";
  const gid_t users = gid_of("users");
  const gid_t nogroup = gid_of("nogroup");
  ASSERT_NE(users, static_cast<gid_t>(-1));
  ASSERT_NE(nogroup, static_cast<gid_t>(-1));
  int n = 16;
  std::vector<gid_t> db(16);
  ASSERT_GE(::getgrouplist("nobody", nogroup, db.data(), &n), 0);
  db.resize(static_cast<std::size_t>(n));
  ASSERT_EQ(std::count(db.begin(), db.end(), users), 0) << "precondition: the database gives nobody no 'users'";

  const PeerCredentials p = connect_as({users}, nogroup, 65534);
  ASSERT_TRUE(p.known);
  EXPECT_EQ(p.uid, 65534u);
  EXPECT_EQ(p.gid, nogroup);
  EXPECT_EQ(p.groups, std::vector<gid_t>{users});
  EXPECT_TRUE(peer_in_group(p, "users"));
  EXPECT_TRUE(peer_in_group(p, "nogroup"));  // the effective gid
  EXPECT_FALSE(peer_in_group(p, "root"));
  EXPECT_FALSE(peer_in_group(p, "no-such-group-cobridge"));
}

// The database makes root a member of group root (its primary group); a
// process of uid 0 that dropped gid 0 (setgroups, setresgid) is no longer
// one: it could not open a 0660 root-group socket either.
TEST(PeerCredentials, AGroupTheProcessDroppedDoesNotCountThoughTheDatabaseGivesIt) {
  ASSERT_EQ(::geteuid(), 0u) << "forks callers with other credentials: run as root";
  const gid_t nogroup = gid_of("nogroup");
  ASSERT_NE(nogroup, static_cast<gid_t>(-1));
  const PeerCredentials p = connect_as({}, nogroup, 0);
  ASSERT_TRUE(p.known);
  EXPECT_EQ(p.uid, 0u);
  EXPECT_TRUE(p.groups.empty());
  EXPECT_FALSE(peer_in_group(p, "root"));
  EXPECT_TRUE(peer_in_group(p, "nogroup"));
}

// More supplementary groups than the first guess of the buffer (64).
TEST(PeerCredentials, ManySupplementaryGroupsAreAllSeen) {
  ASSERT_EQ(::geteuid(), 0u) << "forks callers with other credentials: run as root";
  std::vector<gid_t> many;
  for (gid_t g = 70000; g < 70200; ++g) many.push_back(g);
  many.push_back(gid_of("users"));
  const PeerCredentials p = connect_as(many, gid_of("nogroup"), 65534);
  ASSERT_TRUE(p.known);
  std::vector<gid_t> theirs = p.groups;
  std::sort(theirs.begin(), theirs.end());
  std::sort(many.begin(), many.end());
  EXPECT_EQ(theirs, many);
  EXPECT_TRUE(peer_in_group(p, "users"));
}
