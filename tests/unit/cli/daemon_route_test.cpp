// DaemonRoute: the CLI maps the daemon's error answers to the same exit
// codes as its own failures (docs/operations.md
// "Exit codes"), and works on the bus itself only when no daemon listens.
#include "cli/daemon_route.hpp"
#include "sys/bus_beacon.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

using cobridge::Errc;
using cobridge::cli::JsonParser;
using cobridge::cli::error_of_answer;
using cobridge::cli::via_daemon;

namespace {
cobridge::cli::Json parse(const char* text) {
  auto doc = JsonParser(text).parse();
  EXPECT_TRUE(doc.ok()) << doc.error().message;
  return doc.ok() ? doc.value() : cobridge::cli::Json{};
}
}  // namespace

TEST(DaemonRoute, ErrorAnswerKeepsKindWhereAndAbortCode) {
  const auto e = error_of_answer(parse(
      R"({"ok":false,"error":{"code":"failed","where":"bus 'line1' node 10 object 1234:0","message":"object does not exist",)"
      R"("detail":{"category":"sdo_abort","value":100794368}},"abort_code":"0x06020000"})"));
  EXPECT_EQ(e.kind, Errc::kFailed);
  EXPECT_EQ(cobridge::exit_code(e.kind), 1);
  EXPECT_EQ(e.where, "bus 'line1' node 10 object 1234:0");
  EXPECT_NE(e.message.find("0x06020000"), std::string::npos);
}

TEST(DaemonRoute, EveryKindNameMapsToItsExitCode) {
  for (int k = 0; k <= static_cast<int>(Errc::kInternal); ++k) {
    const auto kind = static_cast<Errc>(k);
    const std::string text = R"({"ok":false,"error":{"code":")" + std::string(cobridge::name(kind)) +
                             R"(","where":"","message":"m"}})";
    EXPECT_EQ(cobridge::exit_code(error_of_answer(parse(text.c_str())).kind), k) << cobridge::name(kind);
  }
}

TEST(DaemonRoute, OlderDaemonsStringErrorIsAFailure) {
  EXPECT_EQ(error_of_answer(parse(R"({"error":"unknown command"})")).kind, Errc::kFailed);
}

TEST(DaemonRoute, NoDaemonListeningMeansWorkDirectly) {
  EXPECT_FALSE(via_daemon("/nonexistent/cobridge/control.sock", "cbt-nobus0", "status", 500).has_value());
}

// A daemon serving the interface is used whatever the
// control path given; one that cannot be reached is an error, never "work
// directly" beside it.
TEST(DaemonRoute, ADaemonServingTheInterfaceIsFoundWhateverTheControlPath) {
  const std::string iface = "cbt-route" + std::to_string(::getpid());
  cobridge::sys::BusBeacon beacon;
  ASSERT_FALSE(beacon.open(iface, "/nonexistent/elsewhere/control.sock"));
  std::atomic<bool> stop{false};
  std::thread served([&] {
    while (!stop) {
      beacon.serve();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  const auto routed = via_daemon("/nonexistent/cobridge/control.sock", iface, "status", 500);
  stop = true;
  served.join();
  ASSERT_TRUE(routed.has_value()) << "worked directly beside a daemon that serves the interface";
  EXPECT_EQ(routed->first.where, "/nonexistent/elsewhere/control.sock");
  EXPECT_NE(routed->first.message.find("cobridged serves " + iface), std::string::npos) << routed->first.message;
}
