// DdsSecurity: DDS Security (OMG DDS Security 1.1) for the DDS output, from
// the [outputs.dds.security] table to the participant QoS (docs/dds.md,
// "Security"). Six files, all or none:
//   identity_ca, identity_certificate, private_key   authentication (PKI-DH, 9.3)
//   permissions_ca, governance, permissions          access control (9.4)
// Cyclone DDS takes them as participant QoS properties (dds.sec.*, "file:"
// URIs) and loads its three builtin plugins, whose folder is found at build
// time (Debian 12 installs them outside the library search path:
// /usr/lib/<multiarch>/libddsc0debian/) or named by plugin_dir.
//
// Everything is checked when the configuration is loaded, so that a wrong
// path or a key anyone may read stops the daemon with the key's name rather
// than with Cyclone's "Error" at participant creation.
//
// Thread contract: the daemon's control thread only (cobridge_plugin_create
// checks, start sets the QoS). Reads files, allocates.
#pragma once

#include <cobridge/plugin_error.hpp>
#include <dds/dds.h>

#include <array>
#include <string>
#include <string_view>
#include <system_error>

namespace cobridge::dds {

// The folder of Cyclone's builtin security plugins this build found.
[[nodiscard]] std::string_view default_security_plugin_dir() noexcept;

struct DdsSecurity {
  std::string identity_ca;           // PEM certificate of the CA that signs identities
  std::string identity_certificate;  // PEM certificate of this gateway, signed by identity_ca
  std::string private_key;           // PEM key of that certificate, unencrypted, mode 0600
  std::string permissions_ca;        // PEM certificate of the CA that signs the two documents
  std::string governance;            // S/MIME signed governance document (.p7s)
  std::string permissions;           // S/MIME signed permissions document of this gateway (.p7s)
  std::string plugin_dir{default_security_plugin_dir()};
  // Read from identity_certificate by check_security (for the log; the
  // permissions' subject_name must name the same subject).
  std::string subject;    // RFC 2253, e.g. "CN=gateway,O=cobridge test"
  std::string not_after;  // "2026-12-27T16:10:36Z"
};

// The six keys of [outputs.dds.security], in the order the docs list them.
struct SecurityFileKey {
  std::string_view key;
  std::string DdsSecurity::*member;
  std::string_view what;  // for messages
};
inline constexpr std::array<SecurityFileKey, 6> kSecurityFileKeys{{
    {"identity_ca", &DdsSecurity::identity_ca, "identity CA certificate"},
    {"identity_certificate", &DdsSecurity::identity_certificate, "identity certificate"},
    {"private_key", &DdsSecurity::private_key, "private key"},
    {"permissions_ca", &DdsSecurity::permissions_ca, "permissions CA certificate"},
    {"governance", &DdsSecurity::governance, "signed governance document"},
    {"permissions", &DdsSecurity::permissions, "signed permissions document"},
}};

// The builtin plugins' files in plugin_dir (authentication, access control,
// cryptography).
inline constexpr std::array<std::string_view, 3> kSecurityPluginFiles{
    "libdds_security_auth.so", "libdds_security_ac.so", "libdds_security_crypto.so"};

// Every file exists, is a regular file and can be read by this process; the
// private key is not readable or writable by group or others; the three
// plugin libraries are in plugin_dir; the identity certificate is a PEM
// X.509 certificate within its validity (fills subject and not_after).
// A failure (ConfigErrc::kBadFile) has the key and the path as its where.
[[nodiscard]] plugin::Error check_security(DdsSecurity& security);

// Adds the dds.sec.* properties that make Cyclone secure the participant
// created with `qos` (names: <dds/security/dds_security_api_defs.h>).
void set_security_properties(dds_qos_t* qos, const DdsSecurity& security);

// The start's log line: on, with the identity, or off and what that means.
[[nodiscard]] std::string security_log_line(const DdsSecurity* security);

// What to add to a failed participant/topic/writer/reader creation's
// message when security is on: where to look.
[[nodiscard]] std::string security_failure_hint(dds_return_t rc, const DdsSecurity& security);

}  // namespace cobridge::dds
