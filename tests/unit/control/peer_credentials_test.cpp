// PeerCredentials: the control socket's write rule
// (docs/operations.md "Access") asks whether the caller is in
// [control] write_group. The answer must be the process's groups as the
// kernel recorded them at connect() (SO_PEERCRED gid, SO_PEERGROUPS), the
// same credentials the kernel checked against the socket file's mode, not
// the user's entry in the group database. A caller the kernel cannot name
// has no identity and may not write. Real Unix sockets
// (and one TCP connection, which carries no credentials); callers with
// other credentials are forked children that change their groups and user
// (needs root, as the machines and CI run).
#include "control/peer_credentials.hpp"

#include <grp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <string>
#include <vector>

using cobridge::control::peer_credentials;
using cobridge::control::peer_in_group;
using cobridge::control::PeerCredentials;
using cobridge::control::write_group_refusal;

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
  // An unknown peer never counts as uid 0 in the write check.
  EXPECT_NE(p.uid, 0u) << "an unknown peer is never taken for root";
  EXPECT_NE(p.gid, 0u) << "nor for group root";
}

// A TCP connection carries no credentials: the kernel answers SO_PEERCRED
// with uid and gid -1 and pid 0 (and no error). That is no identity either.
TEST(PeerCredentials, ATcpPeerHasNoCredentialsAndIsUnknown) {
  const int l = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ASSERT_EQ(::bind(l, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(l, 1), 0);
  ASSERT_EQ(::getsockname(l, reinterpret_cast<sockaddr*>(&a), &len), 0);
  const int c = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_EQ(::connect(c, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  const int s = ::accept4(l, nullptr, nullptr, SOCK_CLOEXEC);
  ASSERT_GE(s, 0);
  const PeerCredentials p = peer_credentials(s);
  ::close(s);
  ::close(c);
  ::close(l);
  EXPECT_FALSE(p.known) << p.to_string();
  EXPECT_EQ(p.to_string(), "unknown peer");
  EXPECT_NE(p.uid, 0u);
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

// The write rule never takes an unknown peer for uid 0 (root)
// and lets it write. A peer without identity is refused whenever the rule
// asks for a user or group, whoever the daemon runs as, with the reason.
TEST(PeerCredentials, AnUnknownPeerIsRefusedAWriteThatNeedsAGroup) {
  const PeerCredentials unknown = peer_credentials(-1);
  ASSERT_FALSE(unknown.known);
  for (const uid_t daemon_uid : {uid_t{0}, uid_t{998}}) {
    for (const char* group : {"root", "cobridge-admin", "no-such-group-cobridge"}) {
      const std::string why = write_group_refusal(unknown, group, daemon_uid);
      EXPECT_NE(why.find("the caller is unknown"), std::string::npos) << group << ", daemon uid " << daemon_uid;
      EXPECT_NE(why.find("write group \"" + std::string(group) + "\" ([control] write_group)"), std::string::npos)
          << why;
    }
  }
  // A write group of "" asks for no identity: whoever may open the socket writes.
  EXPECT_EQ(write_group_refusal(unknown, "", 0), "");
}

// The rule for a peer the kernel named: root, the daemon's own user or a
// member of the group; anyone else refused with its uid.
TEST(PeerCredentials, AKnownPeerWritesAsRootTheDaemonsUserOrAMember) {
  PeerCredentials p;
  p.known = true;
  p.uid = 0;
  p.gid = 0;
  EXPECT_EQ(write_group_refusal(p, "no-such-group-cobridge", 998), "") << "root";
  p.uid = 998;
  p.gid = 998;
  EXPECT_EQ(write_group_refusal(p, "no-such-group-cobridge", 998), "") << "the daemon's own user";
  p.uid = 4711;
  p.gid = 4711;
  EXPECT_EQ(write_group_refusal(p, "no-such-group-cobridge", 998),
            "uid 4711 is not in the write group \"no-such-group-cobridge\" ([control] write_group)");
  p.groups = {gid_of("users")};
  EXPECT_EQ(write_group_refusal(p, "users", 998), "") << "a member";
  EXPECT_EQ(write_group_refusal(p, "", 998), "");
}
