// ControlAnswer: the JSON lines the control socket answers with, for the
// answers that are not the status report: a failure (the one Error shape,
// daemon/base/error.hpp: {"ok":false,"error":{"code":...,"where":...,
// "message":...,"detail":...}}, plus "abort_code" for an SDO abort) and the
// outcome of a client's SDO / NMT / LSS command. `cobridge` reads the
// error's "code" back into its exit code (Errc), so the CLI and the socket
// map a failure the same way.
//
// Thread: any; pure functions.
#pragma once

#include "base/error.hpp"
#include "control/control_request.hpp"
#include "bus/service/service_request.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace cobridge::control {

[[nodiscard]] std::string error_answer(const Error& error, std::uint32_t abort_code = 0);
// {"ok":true,"buses":[...]}
[[nodiscard]] std::string commission_answer(const std::vector<std::string>& buses, const std::string& message = {});
// {"ok":true,"name":"...","text":"..."}: a flight-recorder capture's frames.
[[nodiscard]] std::string capture_answer(const std::string& name, const std::string& text);
// The outcome of `request` (a service kind): an error_answer, or e.g.
// {"ok":true,"bus":"line1","node":10,"index":4120,"sub":4,"size":4,"hex":"E9030000","value":1001}
[[nodiscard]] std::string service_answer(const ControlRequest& request, const bus::ServiceResult& result);

}  // namespace cobridge::control
