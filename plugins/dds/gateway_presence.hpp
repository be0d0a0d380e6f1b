// GatewayPresence: the gateway as a whole on DDS. Writes the gateway's one
// GatewayStatus instance (who it is, which process, how many of its devices
// and buses are alive) and reads every other gateway's, to detect a second
// running gateway with the same gateway_id in the domain: both would write
// the same instances of every topic, so their devices would collide.
//
// Several gateways in one domain (docs/dds.md, "Many gateways in one
// domain"): a subscriber learns of a gateway from its GatewayStatus
// (transient-local), sees it die as NOT_ALIVE_NO_WRITERS on every instance
// after the writers' liveliness lease (topics.hpp), sees it lose its buses as
// devices_online = 0, and sees a duplicate id as duplicate_id = true in the
// GatewayStatus of both.
//
// Thread contract: start/stop on the control thread; poll/publish on the
// plugin's presence thread (one thread) between start and stop. Off the hot
// path: allocates, takes Cyclone's locks.
#pragma once

#include "dds/bus_health_table.hpp"
#include "dds/dds_config.hpp"
#include "dds/pair_role.hpp"
#include "dds/sample_mapping.hpp"

#include <dds/dds.h>

#include <cstdint>
#include <string>
#include <system_error>
#include <vector>

namespace cobridge::dds {

// What GatewayStatus counts; computed by DdsPublisher from its device slots.
struct GatewayCounts {
  std::uint16_t devices = 0;
  std::uint16_t devices_online = 0;
  std::uint16_t buses = 0;
  std::uint16_t buses_online = 0;
  friend bool operator==(const GatewayCounts&, const GatewayCounts&) = default;
};

// What poll() found out about another gateway with this gateway's id.
enum class DuplicateChange : std::uint8_t {
  kNone,      // nothing new
  kDetected,  // another incarnation writes this gateway's key (duplicate_of()
              // says who)
  kGone       // that other gateway stopped or died
};

class GatewayPresence {
 public:
  GatewayPresence(const GatewayName& gateway, std::string topic_prefix, std::string partition, dds_duration_t lease);
  ~GatewayPresence();
  GatewayPresence(const GatewayPresence&) = delete;
  GatewayPresence& operator=(const GatewayPresence&) = delete;

  // Creates topic, writer and reader in `participant` and writes the first
  // GatewayStatus. On failure nothing is left; the error says why, its code
  // is Cyclone's return code (dds_category).
  [[nodiscard]] plugin::Error start(dds_entity_t participant);
  // Disposes the instance (subscribers see the gateway leave at once) and
  // deletes the writer and reader.
  void stop() noexcept;

  // Takes what the reader received; reports a duplicate appearing or going.
  [[nodiscard]] DuplicateChange poll() noexcept;
  // Writes GatewayStatus when the counts, the pair's role, the buses'
  // health or the duplicate state changed since the last write (or always,
  // with force).
  void publish(const GatewayCounts& counts, const PairStatus& pair, const std::vector<BusHealthEntry>& buses,
               bool force = false) noexcept;
  // Hot standby: before start, this gateway's node-ID in the pair. Its
  // GatewayStatus is then keyed by "<gateway_id>#<node>", so the two
  // gateways of a pair (one gateway_id) are two instances, not duplicates.
  void set_pair_node(std::uint8_t node);

  [[nodiscard]] bool duplicate() const noexcept { return !duplicate_of_.empty(); }
  [[nodiscard]] const std::string& duplicate_of() const noexcept { return duplicate_of_; }
  [[nodiscard]] std::uint64_t incarnation() const noexcept { return incarnation_; }
  [[nodiscard]] std::uint64_t writes() const noexcept { return writes_; }

 private:
  void write(std::uint64_t now_ns) noexcept;

  GatewayName gateway_;
  std::string topic_prefix_;
  std::string partition_;
  dds_entity_t publisher_ = 0, subscriber_ = 0;
  dds_duration_t lease_;
  std::string host_;
  std::uint32_t pid_ = 0;
  std::uint64_t incarnation_ = 0;
  std::uint64_t started_ns_ = 0;
  dds_entity_t writer_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t topic_ = 0;
  GatewayCounts counts_{};
  PairStatus pair_{};
  std::vector<BusHealthEntry> buses_;  // GatewayStatus.bus_health
  bool written_duplicate_ = false;
  bool ever_written_ = false;
  std::string duplicate_of_;  // "host pid" of the other gateway, "" = none
  std::uint64_t writes_ = 0;
};

}  // namespace cobridge::dds
