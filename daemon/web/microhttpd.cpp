#include "web/microhttpd.hpp"

#include <dlfcn.h>

#include <string>

namespace cobridge::web {
namespace {

struct Loaded {
  Microhttpd table;
  Error error;  // the first thing missing
};

template <typename F>
void resolve(void* handle, const char* name, F& out, Error& first) {
  out = reinterpret_cast<F>(::dlsym(handle, name));
  if (out == nullptr && first.ok())
    first = Error(Errc::kUnavailable, std::string("no ") + name, microhttpd_library_name());
}

Loaded load() {
  Loaded l;
  // RTLD_NOW: a missing symbol is found here, not in the middle of a request.
  void* h = ::dlopen(microhttpd_library_name(), RTLD_NOW | RTLD_LOCAL);
  if (h == nullptr) {
    const char* why = ::dlerror();
    l.error = Error(Errc::kUnavailable, why != nullptr ? why : std::string("cannot load ") + microhttpd_library_name());
    return l;
  }
  Microhttpd& t = l.table;
  Error& e = l.error;
  resolve(h, "MHD_start_daemon", t.start_daemon, e);
  resolve(h, "MHD_stop_daemon", t.stop_daemon, e);
  resolve(h, "MHD_get_daemon_info", t.get_daemon_info, e);
  resolve(h, "MHD_is_feature_supported", t.is_feature_supported, e);
  resolve(h, "MHD_get_connection_values", t.get_connection_values, e);
  resolve(h, "MHD_lookup_connection_value", t.lookup_connection_value, e);
  resolve(h, "MHD_get_connection_info", t.get_connection_info, e);
  resolve(h, "MHD_basic_auth_get_username_password", t.basic_auth_get_username_password, e);
  resolve(h, "MHD_free", t.free, e);
  resolve(h, "MHD_create_response_from_buffer", t.create_response_from_buffer, e);
  resolve(h, "MHD_add_response_header", t.add_response_header, e);
  resolve(h, "MHD_queue_response", t.queue_response, e);
  resolve(h, "MHD_queue_basic_auth_fail_response", t.queue_basic_auth_fail_response, e);
  resolve(h, "MHD_destroy_response", t.destroy_response, e);
  return l;
}

}  // namespace

const char* microhttpd_library_name() noexcept { return COBRIDGE_MICROHTTPD_SONAME; }

Result<const Microhttpd*> microhttpd() {
  static const Loaded loaded = load();  // thread-safe once (C++11 statics)
  if (loaded.error) return loaded.error;
  return &loaded.table;
}

}  // namespace cobridge::web
