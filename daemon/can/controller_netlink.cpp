#include "can/controller_netlink.hpp"

#include <linux/can/netlink.h>
#include <netlink/netlink.h>
#include <netlink/route/link.h>
#include <netlink/route/link/can.h>

#include <memory>

namespace cobridge::can {

ControllerState to_controller_state(std::uint32_t kernel_state) noexcept {
  switch (kernel_state) {
    case CAN_STATE_ERROR_ACTIVE: return ControllerState::error_active;
    case CAN_STATE_ERROR_WARNING: return ControllerState::error_warning;
    case CAN_STATE_ERROR_PASSIVE: return ControllerState::error_passive;
    case CAN_STATE_BUS_OFF: return ControllerState::bus_off;
    default: return ControllerState::unknown;  // CAN_STATE_STOPPED, CAN_STATE_SLEEPING, newer values
  }
}

bool apply_netlink(ControllerHealth& health, const NetlinkReading& reading, std::int64_t now_ns) noexcept {
  if (!reading.can_device || !reading.has_state) {
    health.driver = DriverReport::no_state;
    if (health.source != HealthSource::netlink) return false;
    health.source = HealthSource::none;
    health.counters_known = false;
    return health.set_state(ControllerState::unknown, now_ns);
  }
  health.driver = DriverReport::state;
  health.source = HealthSource::netlink;
  if (reading.has_berr) {
    health.counters_known = true;
    health.tx_errors = reading.tx_errors;
    health.rx_errors = reading.rx_errors;
  }
  return health.set_state(to_controller_state(reading.state), now_ns);
}

namespace {

Error netlink_error(int nl_err, std::string what, const std::string& interface) {
  // libnl returns negative NLE_* codes; nl_syserr2nlerr is the other way,
  // so the text is libnl's and the precise code stays the errno class.
  const int err = nl_err < 0 ? -nl_err : nl_err;
  const Errc kind = err == NLE_OBJ_NOTFOUND || err == NLE_NODEV ? Errc::kNotFound : Errc::kFailed;
  return Error(kind, what + ": " + nl_geterror(err), "interface " + interface);
}

struct LinkPut {
  void operator()(rtnl_link* l) const noexcept { rtnl_link_put(l); }
};

}  // namespace

ControllerNetlink::~ControllerNetlink() {
  if (sock_ != nullptr) nl_socket_free(sock_);
}

Error ControllerNetlink::connect() {
  sock_ = nl_socket_alloc();
  if (sock_ == nullptr) return Error(Errc::kFailed, "netlink socket: out of memory");
  if (const int err = nl_connect(sock_, NETLINK_ROUTE); err < 0) {
    nl_socket_free(sock_);
    sock_ = nullptr;
    return netlink_error(err, "netlink connect (NETLINK_ROUTE)", "-");
  }
  return {};
}

Result<NetlinkReading> ControllerNetlink::read(const std::string& interface) {
  if (sock_ == nullptr) {
    if (Error e = connect()) {
      e.where = "interface " + interface;
      return e;
    }
  }
  rtnl_link* raw = nullptr;
  if (const int err = rtnl_link_get_kernel(sock_, 0, interface.c_str(), &raw); err < 0)
    return netlink_error(err, "RTM_GETLINK", interface);
  const std::unique_ptr<rtnl_link, LinkPut> link(raw);
  NetlinkReading r;
  r.can_device = rtnl_link_is_can(link.get()) != 0;
  if (!r.can_device) return r;
  std::uint32_t state = 0;
  r.has_state = rtnl_link_can_state(link.get(), &state) == 0;
  r.state = state;
  can_berr_counter berr{};
  r.has_berr = rtnl_link_can_berr(link.get(), &berr) == 0;
  r.tx_errors = berr.txerr;
  r.rx_errors = berr.rxerr;
  return r;
}

}  // namespace cobridge::can
