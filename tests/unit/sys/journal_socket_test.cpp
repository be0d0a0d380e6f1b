// JournalSocket against a datagram socket the test binds where journald's
// would be: the bytes journald's native protocol expects, the large-entry
// path through a memfd, and silence when no journald listens.
#include "sys/journal_socket.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <vector>

#include "unit/support/datagram_receiver.hpp"

using cobridge::sys::journal_datagram;
using cobridge::sys::JournalSocket;

namespace {

namespace test = cobridge::test;

class FakeJournald {
 public:
  const std::string& path() const { return socket_.path(); }

  // One message: its bytes, or the content of the file descriptor it passed.
  std::string next(bool* passed_fd = nullptr) {
    std::vector<char> buf(1 << 16);
    iovec iov{buf.data(), buf.size()};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(socket_.fd(), &msg, 0);
    if (n < 0) return "<nothing>";
    const cmsghdr* c = CMSG_FIRSTHDR(&msg);
    if (passed_fd != nullptr) *passed_fd = c != nullptr && c->cmsg_type == SCM_RIGHTS;
    if (c == nullptr || c->cmsg_type != SCM_RIGHTS) return std::string(buf.data(), static_cast<size_t>(n));
    int mfd = -1;
    std::memcpy(&mfd, CMSG_DATA(c), sizeof mfd);
    struct stat st {};
    ::fstat(mfd, &st);
    std::string content(static_cast<size_t>(st.st_size), '\0');
    EXPECT_EQ(::pread(mfd, content.data(), content.size(), 0), st.st_size);
    ::close(mfd);
    return content;
  }

 private:
  test::DatagramReceiver socket_{"journal-test", 2};
};

}  // namespace

TEST(JournalSocket, PlainFieldsAreKeyEqualsValueLines) {
  EXPECT_EQ(journal_datagram({"MESSAGE=bus line1: serving vcan0", "PRIORITY=6", "SYSLOG_IDENTIFIER=cobridged"}),
            "MESSAGE=bus line1: serving vcan0\nPRIORITY=6\nSYSLOG_IDENTIFIER=cobridged\n");
}

// A value with a newline is sent with its length (64-bit little endian) instead of '='.
TEST(JournalSocket, AValueWithANewlineIsSentWithItsLength) {
  const std::string d = journal_datagram({"MESSAGE=two\nlines", "PRIORITY=3"});
  const std::string expected = std::string("MESSAGE\n") + std::string("\x09\0\0\0\0\0\0\0", 8) + "two\nlines\nPRIORITY=3\n";
  EXPECT_EQ(d, expected);
}

TEST(JournalSocket, SendsOneDatagramPerEntry) {
  FakeJournald journald;
  JournalSocket socket(journald.path());
  EXPECT_EQ(socket.send({"MESSAGE=first", "PRIORITY=6"}), 0);
  EXPECT_EQ(socket.send({"MESSAGE=second\nline", "PRIORITY=4"}), 0);
  bool fd = true;
  EXPECT_EQ(journald.next(&fd), "MESSAGE=first\nPRIORITY=6\n");
  EXPECT_FALSE(fd);
  EXPECT_EQ(journald.next(), journal_datagram({"MESSAGE=second\nline", "PRIORITY=4"}));
}

// Larger than any datagram the socket takes: journald gets it as a sealed memfd.
TEST(JournalSocket, AnEntryTooLargeForADatagramTravelsAsAMemfd) {
  FakeJournald journald;
  JournalSocket socket(journald.path());
  const std::string big(4 << 20, 'x');
  EXPECT_EQ(socket.send({"MESSAGE=" + big, "PRIORITY=6"}), 0);
  bool fd = false;
  EXPECT_EQ(journald.next(&fd), "MESSAGE=" + big + "\nPRIORITY=6\n");
  EXPECT_TRUE(fd);
}

TEST(JournalSocket, NoJournaldIsNotAnError) {
  JournalSocket socket("/tmp/cobridge-journal-test-nobody-" + std::to_string(getpid()));
  EXPECT_EQ(socket.send({"MESSAGE=lost", "PRIORITY=6"}), 0);
}
