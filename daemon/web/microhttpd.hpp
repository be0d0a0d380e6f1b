// Microhttpd: the libmicrohttpd functions the web service calls, resolved
// from the library when the service is first started (dlopen), not linked.
//
// Why: libmicrohttpd brings GnuTLS and its chain (about ten libraries), and a
// daemon without [web] would map and relocate all of them on every start,
// each costing start-up time before the first bus frame. A gateway that
// serves the web page pays for it when it starts the service, after its
// buses are up.
//
// Thread: microhttpd() may be called from any thread (loads once); the table
// it returns is immutable and lives until the process ends (never dlclosed:
// libmicrohttpd's threads may still be unwinding when a server stops).
#pragma once

#include "base/result.hpp"

#include <microhttpd.h>

#include <string>

namespace cobridge::web {

struct Microhttpd {
  decltype(&::MHD_start_daemon) start_daemon = nullptr;
  decltype(&::MHD_stop_daemon) stop_daemon = nullptr;
  decltype(&::MHD_get_daemon_info) get_daemon_info = nullptr;
  decltype(&::MHD_is_feature_supported) is_feature_supported = nullptr;
  decltype(&::MHD_get_connection_values) get_connection_values = nullptr;
  decltype(&::MHD_lookup_connection_value) lookup_connection_value = nullptr;
  decltype(&::MHD_get_connection_info) get_connection_info = nullptr;
  decltype(&::MHD_basic_auth_get_username_password) basic_auth_get_username_password = nullptr;
  decltype(&::MHD_free) free = nullptr;
  decltype(&::MHD_create_response_from_buffer) create_response_from_buffer = nullptr;
  decltype(&::MHD_add_response_header) add_response_header = nullptr;
  decltype(&::MHD_queue_response) queue_response = nullptr;
  decltype(&::MHD_queue_basic_auth_fail_response) queue_basic_auth_fail_response = nullptr;
  decltype(&::MHD_destroy_response) destroy_response = nullptr;
};

// The loaded table, or (kUnavailable) why the library or one of its
// functions is missing ("libmicrohttpd.so.12: cannot open ...").
[[nodiscard]] Result<const Microhttpd*> microhttpd();

// The file loaded (its SONAME, found at build time).
[[nodiscard]] const char* microhttpd_library_name() noexcept;

}  // namespace cobridge::web
