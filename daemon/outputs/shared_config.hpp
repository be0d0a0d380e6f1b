// SharedConfig: the configuration the output side (bridges, command routing)
// works with, replaced as a whole by a SIGHUP reload while the bus control
// threads and the plugins' threads read it. Readers take a snapshot that
// stays valid for as long as they hold it.
// Threads: get() from any thread; set() from the daemon's main thread.
// Never on the hot path.
#pragma once

#include <memory>
#include <mutex>
#include <utility>

#include "config/config.hpp"

namespace cobridge::outputs {

class SharedConfig {
 public:
  explicit SharedConfig(config::Config config) : current_(std::make_shared<const config::Config>(std::move(config))) {}

  [[nodiscard]] std::shared_ptr<const config::Config> get() const {
    const std::lock_guard lock(mutex_);
    return current_;
  }
  void set(config::Config config) {
    auto next = std::make_shared<const config::Config>(std::move(config));
    const std::lock_guard lock(mutex_);
    current_ = std::move(next);
  }

 private:
  mutable std::mutex mutex_;
  std::shared_ptr<const config::Config> current_;
};

}  // namespace cobridge::outputs
