// CommandDesk: where a DCMD becomes a command for the daemon
// (cobridge_host_api.submit_command, plugin ABI 2) and where its outcome
// becomes a result the session publishes back as the device's DDATA
// (Command/Client, Command/Result, Command/Result Code).
//
//   DCMD malformed, device unknown, policy refuses, daemon refuses now
//        -> a result at once (refusal code and the reason in words)
//   DCMD accepted -> nothing yet; the daemon's COMMAND sample with our tag
//        -> a result (0 = done, else enum cobridge_command_status)
// Every DCMD and every outcome is logged with the sender's Command/Client.
//
// Thread contract: the plugin's publisher thread only. It logs and builds
// strings (a command is rare); the pending table is fixed-size.
#pragma once

#include "dcmd_request.hpp"
#include "write_policy.hpp"

#include <cobridge/plugin.h>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace cobridge::mqtt {

// Command/Result Code values beyond enum cobridge_command_status (0..8):
// refusals decided by the plugin before the daemon saw the command.
enum class CommandRefusal : std::int32_t {
  kWritesDisabled = 16,  // writes_enabled = false
  kNotAllowed = 17,      // not in write_allow
  kMalformed = 18,       // the DCMD payload (see DcmdRequest::error)
  kNoCommands = 19,      // the daemon takes no commands (plugin ABI < 2)
};

struct CommandResult {
  std::uint16_t device_index = 0;
  std::string client;
  std::string text;
  std::int32_t code = 0;
};

class CommandDesk {
 public:
  // Returns an enum cobridge_command_status; nullptr when the daemon takes none.
  using Submit = std::function<int(const cobridge_command&)>;
  using LogFn = std::function<void(int level, const std::string& msg)>;

  CommandDesk(WritePolicy policy, Submit submit, LogFn log);

  // A DCMD for the device `device_index` (-1: no device of that id) named `name`.
  [[nodiscard]] std::optional<CommandResult> on_dcmd(const DcmdRequest& r, int device_index, const char* name);
  // The outcome of one of our commands, from its COMMAND sample; nullopt for any other sample.
  [[nodiscard]] std::optional<CommandResult> on_sample(const cobridge_sample& s);

  // Tags of this plugin's commands carry this in their top 16 bits, so that
  // another output's COMMAND samples (every plugin sees every one) never match.
  static constexpr std::uint32_t kTagMark = 0x4D510000u;  // "MQ"

 private:
  struct Pending {
    bool used = false;
    std::uint32_t tag = 0;
    std::uint16_t device_index = 0;
    std::string client;
    std::string what;  // "preset to 1234 on device rot"
  };
  CommandResult refuse(const DcmdRequest& r, int device_index, std::int32_t code, const std::string& why);

  WritePolicy policy_;
  Submit submit_;
  LogFn log_;
  std::array<Pending, 32> pending_{};  // a full table reuses the oldest slot
  std::size_t next_slot_ = 0;
  std::uint16_t next_tag_ = 0;
};

// "the device answered with an SDO abort", ... for enum cobridge_command_status.
[[nodiscard]] const char* command_status_text(int status) noexcept;

}  // namespace cobridge::mqtt
