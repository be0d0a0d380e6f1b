#include "gateway/pending_output.hpp"

#include <sys/socket.h>
#include <sys/types.h>

#include <cerrno>

namespace cobridge::gateway {

bool send_pending(int fd, std::string& out, std::size_t& done) {
  while (done < out.size()) {
    const ssize_t n = ::send(fd, out.data() + done, out.size() - done, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);  // else the client went away
    }
  }
  out.clear();
  done = 0;
  return true;
}

}  // namespace cobridge::gateway
