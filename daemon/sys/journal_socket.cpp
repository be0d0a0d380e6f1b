#include "sys/journal_socket.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <utility>

namespace cobridge::sys {
namespace {

void append_le64(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

socklen_t address_of(const std::string& path, sockaddr_un& addr) {
  addr = {};
  addr.sun_family = AF_UNIX;
  const std::size_t n = std::min(path.size(), sizeof addr.sun_path - 1);
  std::memcpy(addr.sun_path, path.data(), n);
  return static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + n + 1);
}

}  // namespace

std::string journal_datagram(const std::vector<std::string>& fields) {
  std::string out;
  for (const std::string& f : fields) {
    const std::size_t eq = f.find('=');
    const std::string_view key = std::string_view(f).substr(0, eq);
    const std::string_view value = eq == std::string::npos ? std::string_view() : std::string_view(f).substr(eq + 1);
    out.append(key);
    if (value.find('\n') == std::string_view::npos) {
      out.push_back('=');
    } else {
      out.push_back('\n');
      append_le64(out, value.size());
    }
    out.append(value);
    out.push_back('\n');
  }
  return out;
}

JournalSocket::JournalSocket(std::string path) : path_(std::move(path)) {}

JournalSocket::~JournalSocket() {
  if (fd_ >= 0) ::close(fd_);
}

int JournalSocket::send(const std::vector<std::string>& fields) {
  if (fd_ < 0) fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return -errno;
  const std::string datagram = journal_datagram(fields);
  sockaddr_un addr{};
  const socklen_t len = address_of(path_, addr);
  if (::sendto(fd_, datagram.data(), datagram.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&addr), len) >= 0)
    return 0;
  if (errno == ENOENT) return 0;  // no journald: nowhere to log, and nothing to say it with
  if (errno != EMSGSIZE && errno != ENOBUFS) return -errno;
  return send_as_memfd(datagram);
}

// Too large for one datagram: the entry in a sealed memfd, its descriptor
// the message (journald reads the whole file as the entry).
int JournalSocket::send_as_memfd(const std::string& datagram) {
  const int mfd = ::memfd_create("journal-entry", MFD_CLOEXEC | MFD_ALLOW_SEALING);
  if (mfd < 0) return -errno;
  std::size_t done = 0;
  while (done < datagram.size()) {
    const ssize_t n = ::write(mfd, datagram.data() + done, datagram.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(mfd);
      return -err;
    }
    done += static_cast<std::size_t>(n);
  }
  (void)::fcntl(mfd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_WRITE | F_SEAL_SEAL);
  sockaddr_un addr{};
  msghdr msg{};
  msg.msg_name = &addr;
  msg.msg_namelen = address_of(path_, addr);
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  cmsghdr* c = CMSG_FIRSTHDR(&msg);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_RIGHTS;
  c->cmsg_len = CMSG_LEN(sizeof(int));
  std::memcpy(CMSG_DATA(c), &mfd, sizeof(int));
  const ssize_t n = ::sendmsg(fd_, &msg, MSG_NOSIGNAL);
  const int err = errno;
  ::close(mfd);
  return n < 0 ? -err : 0;
}

}  // namespace cobridge::sys
