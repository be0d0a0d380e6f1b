#include "bus/bus_manager.hpp"
#include "bus/service/service_target.hpp"

#include <algorithm>

namespace cobridge::bus {

void BusRegistry::add(BusManager& manager, ServiceBus bus, const config::ServiceAccess& access) {
  const std::lock_guard lock(mutex_);
  entries_.push_back(Entry{&manager, std::move(bus)});
  std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return a.bus.net < b.bus.net; });
  access_ = access;
}

void BusRegistry::update_access(const config::ServiceAccess& access) {
  const std::lock_guard lock(mutex_);
  if (!entries_.empty()) access_ = access;
}

void BusRegistry::remove(const BusManager& manager) {
  const std::lock_guard lock(mutex_);
  std::erase_if(entries_, [&](const Entry& e) { return e.manager == &manager; });
  if (entries_.empty()) access_.reset();
}

std::vector<ServiceBus> BusRegistry::buses() const {
  const std::lock_guard lock(mutex_);
  std::vector<ServiceBus> out;
  for (const auto& e : entries_) out.push_back(e.bus);
  return out;
}

Error BusRegistry::submit(std::string_view bus, ServiceRequest command, std::shared_ptr<ServiceReplies> reply_to) {
  const std::lock_guard lock(mutex_);
  for (const auto& e : entries_) {
    const bool by_net = bus.size() > 1 && bus[0] == '#' && bus.substr(1) == std::to_string(e.bus.net);
    if (e.bus.name != bus && e.bus.interface != bus && !by_net) continue;
    return e.manager->submit_service(std::move(command), std::move(reply_to));
  }
  std::string names;
  for (const auto& e : entries_) names += (names.empty() ? "" : ", ") + e.bus.name + " (" + e.bus.interface + ")";
  return Error(Errc::kNotFound, "the daemon serves no bus \"" + std::string(bus) + "\" (buses: " +
                                    (names.empty() ? "none" : names) + ")");
}

std::optional<config::ServiceAccess> BusRegistry::access() const {
  const std::lock_guard lock(mutex_);
  return access_;
}

}  // namespace cobridge::bus
