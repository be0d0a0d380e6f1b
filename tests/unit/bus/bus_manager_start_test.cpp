// BusManager::start when the bus cannot be opened: the failure comes back as
// one Error whose where names the bus and the interface, and nothing below
// the daemon logs it (the daemon logs it once, with that where). No CAN
// socket is needed: an interface name longer than IFNAMSIZ - 1 fails before
// socket(PF_CAN) is called.
#include <spdlog/sinks/ringbuffer_sink.h>

#include <filesystem>

#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "bus/bus_manager.hpp"
#include "bus/state_store.hpp"
#include "sys/logging.hpp"
#include "unit/bus/virtual_line.hpp"

namespace cobridge::bus {
namespace {

TEST(BusManagerStart, OpenFailureIsReturnedWithItsWhereAndLoggedByNobodyBelow) {
  const auto dir = std::filesystem::temp_directory_path() / ("cobridge-bm-start-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  config::Config cfg;
  config::Bus bus;
  bus.name = "line1";
  bus.interface = "can-name-too-long-for-linux";  // > IFNAMSIZ - 1 (15) characters
  cfg.buses.push_back(bus);
  const device::DeviceCatalog catalog;
  StateStore store(dir);
  Error e;
  std::vector<std::string> logged;
  {
    const test::LogCapture capture;
    BusManager manager(cfg, 0, catalog, store);
    e = manager.start();
    logged = capture.lines();
  }
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument) << e.to_string();
  EXPECT_EQ(e.where, "bus line1: can-name-too-long-for-linux");
  EXPECT_NE(e.message.find("IFNAMSIZ"), std::string::npos) << e.message;
  EXPECT_TRUE(logged.empty()) << "logged below the daemon: " << logged.front();
}

}  // namespace
}  // namespace cobridge::bus
