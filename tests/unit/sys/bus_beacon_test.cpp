// BusBeacon: a running daemon is found from the name of
// the interface it serves, whatever its control socket's path.
#include "sys/bus_beacon.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <string>
#include <thread>

using cobridge::Errc;
using cobridge::Error;
using cobridge::sys::BusBeacon;
using cobridge::sys::find_bus_owner;

namespace {

// An interface name no other test process uses.
std::string test_iface(const char* tag) { return std::string("cbt") + tag + std::to_string(::getpid()); }

// Serves `beacon` as the daemon's main loop does, until destroyed.
class Served {
 public:
  explicit Served(BusBeacon& b) : thread_([this, &b] {
      while (!stop_) {
        b.serve();
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }) {}
  ~Served() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(BusBeacon, NoDaemonMeansNoOwnerAndNoError) {
  Error e;
  EXPECT_FALSE(find_bus_owner(test_iface("none"), 200, e));
  EXPECT_FALSE(e) << e.to_string();
}

TEST(BusBeacon, TheOwnerSaysItsPidAndControlSocket) {
  const std::string iface = test_iface("own");
  BusBeacon beacon;
  ASSERT_FALSE(beacon.open(iface, "/run/elsewhere/control.sock"));
  Served served(beacon);
  Error e;
  const auto owner = find_bus_owner(iface, 2000, e);
  ASSERT_TRUE(owner) << e.to_string();
  EXPECT_EQ(owner->pid, ::getpid());
  EXPECT_EQ(owner->control, "/run/elsewhere/control.sock");
}

TEST(BusBeacon, ASecondDaemonOnTheSameInterfaceIsToldWhoServesIt) {
  const std::string iface = test_iface("two");
  BusBeacon first;
  ASSERT_FALSE(first.open(iface, "/run/a/control.sock"));
  Served served(first);
  BusBeacon second;
  const Error e = second.open(iface, "/run/b/control.sock");
  EXPECT_EQ(e.kind, Errc::kUnavailable);
  EXPECT_NE(e.message.find("pid " + std::to_string(::getpid()) + ", control socket /run/a/control.sock"),
            std::string::npos)
      << e.message;
  EXPECT_EQ(second.fd(), -1);
}

TEST(BusBeacon, AListenerThatDoesNotAnswerIsAnErrorNotNoOwner) {
  const std::string iface = test_iface("mute");
  BusBeacon beacon;
  ASSERT_FALSE(beacon.open(iface, "/run/x/control.sock"));  // never served
  Error e;
  EXPECT_FALSE(find_bus_owner(iface, 100, e));
  EXPECT_EQ(e.kind, Errc::kUnavailable);
  EXPECT_NE(e.message.find("did not say"), std::string::npos) << e.message;
}

TEST(BusBeacon, ClosingFreesTheName) {
  const std::string iface = test_iface("free");
  BusBeacon beacon;
  ASSERT_FALSE(beacon.open(iface, "/run/x/control.sock"));
  beacon.close();
  BusBeacon again;
  EXPECT_FALSE(again.open(iface, "/run/y/control.sock"));
}

}  // namespace
