#include "dds/dds_security.hpp"

#include "dds/dds_config.hpp"

#include <dds/security/dds_security_api_defs.h>
#include <fcntl.h>
#include <openssl/bio.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <memory>

#ifndef COBRIDGE_DDS_SECURITY_PLUGIN_DIR
#error "COBRIDGE_DDS_SECURITY_PLUGIN_DIR: set by plugins/dds/CMakeLists.txt"
#endif

namespace cobridge::dds {
namespace {

std::string mode_text(mode_t mode) {
  std::string s = "0";
  for (const int shift : {6, 3, 0}) s += static_cast<char>('0' + ((mode >> shift) & 7));
  return s;
}

std::string where(std::string_view key, const std::string& path) {
  return "'security." + std::string(key) + "' (" + path + ")";
}

// Opened and read by this process, as Cyclone will be: the test of access,
// not the mode bits (root reads anything; another user's 0600 file fails).
plugin::Error check_file(std::string_view key, const std::string& path, bool secret) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return {DdsConfigErrc::kBadFile, std::strerror(errno), where(key, path)};
  struct stat st {};
  char byte = 0;
  const bool stat_ok = ::fstat(fd, &st) == 0;
  const ssize_t n = stat_ok && S_ISREG(st.st_mode) ? ::read(fd, &byte, 1) : 0;
  const int read_errno = errno;
  ::close(fd);
  std::string message;
  if (!stat_ok || !S_ISREG(st.st_mode)) {
    message = "not a regular file";
  } else if (n < 0) {
    message = std::strerror(read_errno);
  } else if (n == 0) {
    message = "empty";
  } else if (secret && (st.st_mode & 077) != 0) {
    // Whoever can read the key can pose as this gateway to every subscriber.
    message = "readable or writable by group or others (mode " + mode_text(st.st_mode & 0777) + "); chmod 600 it";
  } else {
    return {};
  }
  return {DdsConfigErrc::kBadFile, std::move(message), where(key, path)};
}

plugin::Error check_plugins(const std::string& dir) {
  for (const std::string_view file : kSecurityPluginFiles) {
    const std::string path = dir + "/" + std::string(file);
    if (::access(path.c_str(), R_OK) == 0) continue;
    return {DdsConfigErrc::kBadFile,
            std::string(std::strerror(errno)) +
                " (Debian 12: package libddsc0debian; 'security.plugin_dir' names another folder)",
            "DDS Security plugin " + path};
  }
  return {};
}

struct BioFree {
  void operator()(BIO* b) const noexcept { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const noexcept { X509_free(x); }
};

std::string iso_time(const ASN1_TIME* t) {
  std::tm tm{};
  if (t == nullptr || ASN1_TIME_to_tm(t, &tm) != 1) return "?";
  char buf[32];
  return std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm) != 0 ? buf : "?";
}

// The subject in RFC 2253 form, the form of a permissions document's
// subject_name (OMG DDS Security 1.1, 9.4.1.3.2.1).
std::string subject_of(const X509* cert) {
  const std::unique_ptr<BIO, BioFree> out(BIO_new(BIO_s_mem()));
  if (!out || X509_NAME_print_ex(out.get(), X509_get_subject_name(cert), 0, XN_FLAG_RFC2253) < 0) return "?";
  char* data = nullptr;
  const long len = BIO_get_mem_data(out.get(), &data);
  return len > 0 ? std::string(data, static_cast<std::size_t>(len)) : std::string();
}

// Cyclone refuses a certificate outside its validity with "Error" only.
plugin::Error read_identity(DdsSecurity& s) {
  const std::string place = where("identity_certificate", s.identity_certificate);
  const std::unique_ptr<BIO, BioFree> in(BIO_new_file(s.identity_certificate.c_str(), "r"));
  const std::unique_ptr<X509, X509Free> cert(in ? PEM_read_bio_X509(in.get(), nullptr, nullptr, nullptr) : nullptr);
  if (!cert) return {DdsConfigErrc::kBadFile, "not a PEM X.509 certificate", place};
  s.subject = subject_of(cert.get());
  s.not_after = iso_time(X509_get0_notAfter(cert.get()));
  if (X509_cmp_current_time(X509_get0_notAfter(cert.get())) <= 0)
    return {DdsConfigErrc::kBadFile, "expired on " + s.not_after, place};
  if (X509_cmp_current_time(X509_get0_notBefore(cert.get())) >= 0)
    return {DdsConfigErrc::kBadFile, "not valid before " + iso_time(X509_get0_notBefore(cert.get())), place};
  return {};
}

std::string file_uri(const std::string& path) { return "file:" + path; }

}  // namespace

std::string_view default_security_plugin_dir() noexcept { return COBRIDGE_DDS_SECURITY_PLUGIN_DIR; }

plugin::Error check_security(DdsSecurity& security) {
  for (const SecurityFileKey& k : kSecurityFileKeys) {
    const bool secret = k.member == &DdsSecurity::private_key;
    if (plugin::Error e = check_file(k.key, security.*k.member, secret)) return e;
  }
  if (plugin::Error e = check_plugins(security.plugin_dir)) return e;
  return read_identity(security);
}

void set_security_properties(dds_qos_t* qos, const DdsSecurity& s) {
  // Each plugin by full path: Cyclone dlopens a name with a '/' as it is,
  // and the Debian folder is not on the search path.
  struct Plugin {
    const char *path_key, *init_key, *finalize_key;
    std::string_view file;
    const char *init, *finalize;
  };
  const Plugin plugins[] = {
      {DDS_SEC_PROP_AUTH_LIBRARY_PATH, DDS_SEC_PROP_AUTH_LIBRARY_INIT, DDS_SEC_PROP_AUTH_LIBRARY_FINALIZE,
       kSecurityPluginFiles[0], "init_authentication", "finalize_authentication"},
      {DDS_SEC_PROP_ACCESS_LIBRARY_PATH, DDS_SEC_PROP_ACCESS_LIBRARY_INIT, DDS_SEC_PROP_ACCESS_LIBRARY_FINALIZE,
       kSecurityPluginFiles[1], "init_access_control", "finalize_access_control"},
      {DDS_SEC_PROP_CRYPTO_LIBRARY_PATH, DDS_SEC_PROP_CRYPTO_LIBRARY_INIT, DDS_SEC_PROP_CRYPTO_LIBRARY_FINALIZE,
       kSecurityPluginFiles[2], "init_crypto", "finalize_crypto"},
  };
  for (const Plugin& p : plugins) {
    dds_qset_prop(qos, p.path_key, (s.plugin_dir + "/" + std::string(p.file)).c_str());
    dds_qset_prop(qos, p.init_key, p.init);
    dds_qset_prop(qos, p.finalize_key, p.finalize);
  }
  dds_qset_prop(qos, DDS_SEC_PROP_AUTH_IDENTITY_CA, file_uri(s.identity_ca).c_str());
  dds_qset_prop(qos, DDS_SEC_PROP_AUTH_IDENTITY_CERT, file_uri(s.identity_certificate).c_str());
  dds_qset_prop(qos, DDS_SEC_PROP_AUTH_PRIV_KEY, file_uri(s.private_key).c_str());
  dds_qset_prop(qos, DDS_SEC_PROP_ACCESS_PERMISSIONS_CA, file_uri(s.permissions_ca).c_str());
  dds_qset_prop(qos, DDS_SEC_PROP_ACCESS_GOVERNANCE, file_uri(s.governance).c_str());
  dds_qset_prop(qos, DDS_SEC_PROP_ACCESS_PERMISSIONS, file_uri(s.permissions).c_str());
}

std::string security_log_line(const DdsSecurity* s) {
  if (s == nullptr) return "DDS Security: off (any participant on the network may read the topics)";
  return "DDS Security: on, identity '" + s->subject + "' (certificate valid until " + s->not_after +
         "), governance " + s->governance + ", permissions " + s->permissions;
}

std::string security_failure_hint(dds_return_t rc, const DdsSecurity& s) {
  if (rc == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) {
    return " (the permissions document " + s.permissions + " does not grant it to '" + s.subject + "')";
  }
  return " (DDS Security: Cyclone's reason is logged just before this; check that identity_certificate is signed "
         "by identity_ca and private_key is its key, that governance and permissions are signed by permissions_ca, "
         "and that the permissions' subject_name is '" +
         s.subject + "')";
}

}  // namespace cobridge::dds
