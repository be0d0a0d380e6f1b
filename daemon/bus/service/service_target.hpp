// ServiceTarget: where the control socket and the ASCII gateway send
// ServiceRequests: the running bus managers, by bus name, interface or
// CiA 309-3 net number (the bus's position in the configuration, from 1).
//
// BusRegistry is the daemon's implementation: every BusManager joins it
// when it starts and leaves it when it stops, together with the
// [control]/[ascii_gateway] settings it was started or reloaded with. The
// control socket uses the process's registry unless given another target
// (tests give a fake).
//
// Thread contract: every method may be called from any thread (a mutex;
// submit() holds it while queueing, so a bus manager cannot stop under it).
// Never on the hot path.
#pragma once

#include "base/error.hpp"
#include "config/service_access.hpp"
#include "bus/service/service_request.hpp"
#include "bus/service/service_replies.hpp"

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::bus {

class BusManager;

struct ServiceBus {
  std::string name;
  std::string interface;
  unsigned net = 0;  // CiA 309-3 network number: position in the configuration, from 1
};

class ServiceTarget {
 public:
  virtual ~ServiceTarget() = default;
  [[nodiscard]] virtual std::vector<ServiceBus> buses() const = 0;
  // `bus`: a bus name, an interface, or "#<net>". Errors: kNotFound (no such
  // bus: the message lists them), kUnavailable (its queue is full).
  [[nodiscard]] virtual Error submit(std::string_view bus, ServiceRequest command,
                                     std::shared_ptr<ServiceReplies> reply_to) = 0;
  // The settings of the running daemon; nullopt while no bus runs.
  [[nodiscard]] virtual std::optional<config::ServiceAccess> access() const = 0;
};

class BusRegistry final : public ServiceTarget {
 public:
  void add(BusManager& manager, ServiceBus bus, const config::ServiceAccess& access);
  void update_access(const config::ServiceAccess& access);
  void remove(const BusManager& manager);

  [[nodiscard]] std::vector<ServiceBus> buses() const override;
  [[nodiscard]] Error submit(std::string_view bus, ServiceRequest command,
                             std::shared_ptr<ServiceReplies> reply_to) override;
  [[nodiscard]] std::optional<config::ServiceAccess> access() const override;

 private:
  struct Entry {
    BusManager* manager = nullptr;
    ServiceBus bus;
  };
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;
  std::optional<config::ServiceAccess> access_;
};

}  // namespace cobridge::bus
