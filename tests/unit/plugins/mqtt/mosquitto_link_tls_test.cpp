// The MQTT client over TLS ([outputs.mqtt] ca_file, cert_file, key_file;
// docs/mqtt.md): against Debian's mosquitto with a TLS listener that
// requires a client certificate, all made here by the openssl command line
// (a test CA, the broker's certificate for 127.0.0.1, the gateway's
// certificate, and a second CA nobody signed with). The session comes up
// with the right CA and the gateway's certificate, and does not with a
// broker of another CA or without a client certificate (the client keeps
// retrying, as for any broker not reached).
#include "local_broker.hpp"
#include "mosquitto_link.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace cobridge::mqtt {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace test;

// The test PKI, EC P-256 keys (quick to make), valid two days.
bool make_pki(const fs::path& dir) {
  const std::string d = dir.string();
  const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
  const std::string cmd =
      "cd '" + d + "' && exec >openssl.log 2>&1 && "
      "openssl req -x509" + key + " -keyout ca.key -out ca.pem -days 2 -subj /CN=cobridge-test-ca && "
      "openssl req -x509" + key + " -keyout other.key -out other.pem -days 2 -subj /CN=another-ca && "
      "openssl req" + key + " -keyout server.key -out server.csr -subj /CN=localhost && "
      "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext && "
      "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 2 "
      "-extfile server.ext && "
      "openssl req" + key + " -keyout client.key -out client.csr -subj /CN=gw1 && "
      "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out client.pem -days 2";
  return std::system(cmd.c_str()) == 0;
}

class TlsBroker : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir = fs::temp_directory_path() / ("cobridge-tls-broker-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    pki_made = make_pki(dir);
  }
  static void TearDownTestSuite() { fs::remove_all(dir); }

  void SetUp() override {
    ASSERT_TRUE(pki_made) << "openssl failed; see " << (dir / "openssl.log");
    const std::uint16_t port = free_port();
    const fs::path conf = dir / ("broker-" + std::to_string(port) + ".conf");
    std::ofstream(conf) << "per_listener_settings false\nallow_anonymous true\nuser root\n"
                        << "listener " << port << "\n"  // all addresses: 127.0.0.2 too
                        << "cafile " << (dir / "ca.pem").string() << "\n"
                        << "certfile " << (dir / "server.pem").string() << "\n"
                        << "keyfile " << (dir / "server.key").string() << "\n"
                        << "require_certificate true\n";
    broker = std::make_unique<Broker>(port, conf.string());
    ASSERT_TRUE(wait_for([&] { return accepts(port); }, 5s)) << "mosquitto -c " << conf;
    config.port = port;
    config.edge_node_id = "gw1";
    config.client_id = "tls-test";
    config.group_id = "unit";
    config.ca_file = (dir / "ca.pem").string();
    config.cert_file = (dir / "client.pem").string();
    config.key_file = (dir / "client.key").string();
  }

  // Whether a session comes up within `limit`, the client serviced as the publisher thread does.
  bool session_within(std::chrono::milliseconds limit) {
    BdSeqFile bd((dir / ("bdseq-" + config.client_id)).string(), log);
    bd.load();
    MosquittoLink link(config, bd, log);
    if (link.start()) return false;
    const bool up = wait_for([&] { return serviced(link); }, limit);
    link.stop();
    return up;
  }

  static inline fs::path dir;
  static inline bool pki_made = false;
  std::unique_ptr<Broker> broker;
  MqttConfig config;
  std::string logged;  // what the client said, a line each
  MosquittoLink::LogFn log = [this](int, const std::string& m) { logged += m + "\n"; };
};

TEST_F(TlsBroker, MutualTlsSessionComesUp) {
  EXPECT_TRUE(session_within(5s)) << logged;
  EXPECT_EQ(logged.find("not reached"), std::string::npos) << logged;
}

TEST_F(TlsBroker, BrokerOfAnotherCaRefused) {
  config.ca_file = (dir / "other.pem").string();
  EXPECT_FALSE(session_within(2500ms)) << "the broker's certificate is not of the configured CA";
  EXPECT_NE(logged.find("certificate verify failed"), std::string::npos) << logged;
}

TEST_F(TlsBroker, NoClientCertificateRefused) {
  config.cert_file.clear();
  config.key_file.clear();
  EXPECT_FALSE(session_within(2500ms)) << "the broker requires a client certificate";
  // TLS 1.3: the broker's refusal arrives after the handshake, as an alert
  // libmosquitto reports as a protocol error, without OpenSSL's text.
  EXPECT_NE(logged.find("not reached"), std::string::npos) << logged;
}

// The broker's certificate names 127.0.0.1 and localhost, not another
// address of this host: the name is checked, not only the CA.
TEST_F(TlsBroker, CertificateForAnotherNameRefused) {
  config.host = "127.0.0.2";
  EXPECT_FALSE(session_within(2500ms)) << "127.0.0.2 is not in the certificate";
  EXPECT_NE(logged.find("certificate verify failed"), std::string::npos) << logged;
}

}  // namespace
}  // namespace cobridge::mqtt
