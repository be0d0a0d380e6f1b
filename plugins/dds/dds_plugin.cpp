// Cyclone DDS output plugin (libcobridge_dds.so): the C entry point and ops
// table of cobridge/plugin.h around DdsPublisher.
//
// Configuration (TOML keys of the instance's table, see docs/dds.md):
//   domain             = 0              DDS domain id
//   sample_reliability = "best-effort"  or "reliable" (EncoderSample only)
//   sample_depth       = 1              EncoderSample keep-last depth
//   topic_prefix       = ""             prepended to the topic names
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread, where DdsPublisher writes
// directly (no queue, no allocation per sample).
#include "dds/dds_config.hpp"
#include "dds/dds_publisher.hpp"

#include <cobridge/plugin.h>

#include "host_log.hpp"

#include <cstring>
#include <exception>
#include <memory>
#include <string>

namespace cobridge::dds {
namespace {

struct Instance {
  const cobridge_host_api* host = nullptr;
  std::unique_ptr<DdsPublisher> publisher;

  void log(int level, const std::string& msg) const noexcept {
    plugin::host_log(host, level, msg);
  }
};

using plugin::copy_error;

int dds_start(void* self) {
  auto* inst = static_cast<Instance*>(self);
  try {
    std::string message;
    if (const std::error_code ec = inst->publisher->start(message)) {
      inst->log(COBRIDGE_LOG_ERROR, message);
      return -1;
    }
    const DdsConfig& c = inst->publisher->config();
    inst->log(COBRIDGE_LOG_INFO, "publishing on domain " + std::to_string(c.domain) + ", samples " +
                                     std::string(to_string(c.sample_reliability)) + " keep-last " +
                                     std::to_string(c.sample_depth) +
                                     (c.topic_prefix.empty() ? std::string() : ", topic prefix '" + c.topic_prefix + "'"));
    return 0;
  } catch (const std::exception& e) {
    inst->log(COBRIDGE_LOG_ERROR, std::string("start: ") + e.what());
  } catch (...) {
    inst->log(COBRIDGE_LOG_ERROR, "start: unknown exception");
  }
  inst->publisher->stop();
  return -1;
}

void dds_stop(void* self) {
  auto* inst = static_cast<Instance*>(self);
  inst->publisher->stop();
  const PublisherStats s = inst->publisher->stats();
  try {
    std::string msg = "stopped: " + std::to_string(s.samples) + " samples, " + std::to_string(s.events) +
                      " events, " + std::to_string(s.statuses) + " status updates written";
    if (s.write_failures != 0) {
      msg += "; " + std::to_string(s.write_failures) + " writes failed (last: " + dds_strretcode(s.last_failure) + ")";
    }
    inst->log(s.write_failures != 0 ? COBRIDGE_LOG_WARN : COBRIDGE_LOG_INFO, msg);
  } catch (...) {
    // Logging is best effort; stop itself has succeeded.
  }
}

void dds_destroy(void* self) { delete static_cast<Instance*>(self); }

void dds_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  if (samples == nullptr || count == 0) return;
  static_cast<Instance*>(self)->publisher->publish({samples, count});
}

void dds_on_device(void* self, const cobridge_device_info* info) {
  // Every field used exists since ABI 1; the size check keeps a shorter
  // layout from an unexpected host from being read past its end.
  if (info == nullptr ||
      info->struct_size < offsetof(cobridge_device_info, position_unit) + sizeof(const char*)) {
    return;
  }
  static_cast<Instance*>(self)->publisher->device(*info);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION,
    sizeof(cobridge_plugin_ops),
    "dds",
    &dds_start,
    &dds_stop,
    &dds_destroy,
    &dds_on_samples,
    &dds_on_device,
};

}  // namespace
}  // namespace cobridge::dds

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::dds;
  if (host == nullptr || ops_out == nullptr || self_out == nullptr) {
    copy_error(err, err_len, "dds: null argument");
    return -1;
  }
  try {
    DdsConfigResult parsed =
        parse_dds_config(std::string_view(config_toml != nullptr ? config_toml : "", config_toml ? config_len : 0));
    if (!parsed.ok()) {
      copy_error(err, err_len, parsed.message);
      return -1;
    }
    const char* gateway_id = host->gateway_id != nullptr ? host->gateway_id : "";
    auto inst = std::make_unique<Instance>();
    inst->host = host;
    inst->publisher = std::make_unique<DdsPublisher>(std::move(parsed.config), gateway_id);
    if (*gateway_id == '\0') {
      inst->log(COBRIDGE_LOG_WARN, "the gateway id is empty: keys of several gateways in one domain will collide");
    }
    *ops_out = &kOps;
    *self_out = inst.release();
    return 0;
  } catch (const std::exception& e) {
    copy_error(err, err_len, std::string("dds: ") + e.what());
  } catch (...) {
    copy_error(err, err_len, "dds: unknown exception");
  }
  return -1;
}
