// LineConnection (bus/service/line_connection.hpp): how the control socket and
// the CiA 309-3 gateway receive request lines and send answers, over a real
// socket pair.
#include "control/line_connection.hpp"

#include <gtest/gtest.h>

#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace {

using cobridge::control::LineConnection;

class LineConnectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    int sv[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, sv), 0);
    conn_.fd = sv[0];
    peer_ = sv[1];
  }
  void TearDown() override {
    ::close(conn_.fd);
    if (peer_ >= 0) ::close(peer_);
  }
  void send(const std::string& s) { ASSERT_EQ(::write(peer_, s.data(), s.size()), static_cast<ssize_t>(s.size())); }
  LineConnection conn_;
  int peer_ = -1;
};

TEST_F(LineConnectionTest, StopsAtTheFirstWholeLineAndKeepsThePipelinedRest) {
  send("status\ncommission\n");
  conn_.read(256);
  EXPECT_TRUE(conn_.has_line());
  EXPECT_EQ(conn_.in.substr(0, conn_.in.find('\n')), "status");
  EXPECT_FALSE(conn_.peer_closed);
}

// CiA 309-3 clients end a request with CR LF, others with LF: the line taken
// is the same; a CR elsewhere is the line's own.
TEST_F(LineConnectionTest, ALineIsTakenWithoutItsLfOrCrLf) {
  send("[1] info version\r\n[2] help\n\r\n");
  conn_.read(256);
  ASSERT_TRUE(conn_.has_line());
  EXPECT_EQ(conn_.take_line(), "[1] info version");
  EXPECT_EQ(conn_.take_line(), "[2] help");
  EXPECT_EQ(conn_.take_line(), "");
  EXPECT_EQ(conn_.in, "");
  EXPECT_EQ(cobridge::control::line_body("a\rb\r\r\n"), "a\rb\r");
  EXPECT_EQ(cobridge::control::line_body("half\r"), "half");
}

TEST_F(LineConnectionTest, BuffersAtMostOneLinePlusOneByte) {
  send(std::string(5000, 'x'));
  conn_.read(100);
  EXPECT_EQ(conn_.in.size(), 101U);  // enough to know the line is too long, no more
  EXPECT_FALSE(conn_.has_line());
}

TEST_F(LineConnectionTest, SkippingDropsTheRestOfAnOverlongLine) {
  send(std::string(300, 'y') + "\nnext\n");
  conn_.skipping = true;
  conn_.read(1024);
  EXPECT_FALSE(conn_.skipping);
  EXPECT_EQ(conn_.in, "next\n");
}

TEST_F(LineConnectionTest, EndOfInputIsSeen) {
  send("half");
  ::close(peer_);
  peer_ = -1;
  conn_.read(256);
  EXPECT_EQ(conn_.in, "half");
  EXPECT_TRUE(conn_.peer_closed);
}

TEST_F(LineConnectionTest, FlushSendsWhatFitsAndKeepsTheRest) {
  int size = 4096;
  ASSERT_EQ(::setsockopt(conn_.fd, SOL_SOCKET, SO_SNDBUF, &size, sizeof size), 0);
  conn_.out = std::string(1 << 20, 'a');  // far more than the socket takes
  EXPECT_TRUE(conn_.flush());             // EAGAIN is not a gone client
  EXPECT_TRUE(conn_.writing());
  EXPECT_GT(conn_.out_done, 0U);
  ::close(peer_);
  peer_ = -1;
  EXPECT_FALSE(conn_.flush());  // EPIPE: the client is gone
}

TEST_F(LineConnectionTest, AFlushedAnswerIsCleared) {
  conn_.out = "{\"ok\":true}\n";
  EXPECT_TRUE(conn_.flush());
  EXPECT_TRUE(conn_.out.empty());
  EXPECT_EQ(conn_.out_done, 0U);
  char buf[64] = {};
  EXPECT_EQ(::read(peer_, buf, sizeof buf), 12);
}

}  // namespace
