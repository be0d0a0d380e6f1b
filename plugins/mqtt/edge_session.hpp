// EdgeSession: the Sparkplug B edge node session of one gateway (spec 5,
// "Operational Behavior"): what to publish, in which order, with which
// sequence numbers, given what the MQTT link, the primary host and the
// devices do. It knows no socket: it hands each message to a Publisher, so
// the unit tests drive it with a fake one and a fake clock (time is passed
// in, in ms since the Unix epoch).
//
//   link up (new MQTT session, bdSeq b)  -> NBIRTH (seq 0, bdSeq b, Node
//        Control/Rebirth), then a DBIRTH for every device online; unless a
//        primary host is configured and not online (then held until it is)
//   sample of a born device               -> DDATA by alias, only metrics that
//        changed beyond their deadband, each stamped with the frame's receive time
//   STATUS online=0 of a born device      -> DDEATH; STATUS online=1 -> DBIRTH
//   sample while not publishing           -> the device's HistoryBuffer (store
//        and forward); after the next births every device's history as DDATA
//        with is_historical = true, oldest first, in seq like any DDATA
//   rebirth()  (NCMD Node Control/Rebirth) -> NBIRTH + every DBIRTH again
//   publish_result() (a DCMD's outcome)    -> DDATA of Command/Client,
//        Command/Result, Command/Result Code (declared in every DBIRTH)
// seq runs 0..255 over NBIRTH, DBIRTH, DDATA and DDEATH and restarts at 0
// with each NBIRTH (spec 6.4.3: tck-id-payloads-sequence-num-*).
//
// Thread contract: one thread only (the plugin's publisher thread); stats()
// counters are atomics, read from the daemon's control plane.
#pragma once

#include "command_desk.hpp"
#include "device_record.hpp"
#include "history_buffer.hpp"
#include "sparkplug_metrics.hpp"
#include "sparkplug_payload.hpp"

#include <cobridge/plugin.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace cobridge::mqtt {

// Where a session's messages go. Sparkplug publishes every session message
// with QoS 0 and retain false (spec 5: tck-id-topics-nbirth-mqtt, -dbirth-,
// -ddata-, -ddeath-), so the call has no options. Returns false when the
// message could not be handed to the client (counted as a drop).
class Publisher {
 public:
  virtual ~Publisher() = default;
  virtual bool publish(const std::string& topic, std::span<const std::uint8_t> payload) = 0;
};

struct SessionCounters {
  std::atomic<std::uint64_t> births{0};    // NBIRTH + DBIRTH
  std::atomic<std::uint64_t> deaths{0};    // DDEATH
  std::atomic<std::uint64_t> messages{0};  // every message handed over
  std::atomic<std::uint64_t> bytes{0};     // their payload bytes
  std::atomic<std::uint64_t> drops{0};     // refused by the client, too big, or samples taken while not publishing
  std::atomic<std::uint64_t> stored{0};        // DDATA entries kept while not publishing
  std::atomic<std::uint64_t> store_drops{0};   // ... dropped again (store full or older than its window)
  std::atomic<std::uint64_t> replayed{0};      // ... sent as historical DDATA
};

// The session's clock: wall time in ms since the Unix epoch (Sparkplug
// timestamps are UTC ms, spec 6.4.2). Any thread.
[[nodiscard]] std::uint64_t wall_ms() noexcept;

// "spBv1.0/<group>/<type>/<edge>[/<device>]" (spec 4.1.1).
[[nodiscard]] std::string sparkplug_topic(const std::string& group, const char* type, const std::string& edge,
                                          const std::string& device = {});

// The NDEATH payload (spec 6.4.19: bdSeq only, no seq); used as the MQTT
// will. Returns the size written to `out`, 0 when it does not fit.
[[nodiscard]] std::size_t encode_ndeath(PayloadBuilder& b, std::uint8_t bd_seq, std::uint64_t now_ms,
                                        std::span<std::uint8_t> out) noexcept;

class EdgeSession {
 public:
  struct Ids {
    std::string group_id;
    std::string edge_node_id;
    bool wait_for_primary = false;
    // Store and forward: entries per device (0 = off) and their window.
    std::size_t store_capacity = 0;
    std::uint64_t store_window_ms = 0;
    // Batching: on_sample() queues a device's DDATA (at most this many
    // samples) until flush(); 0 = each sample's DDATA at once.
    std::size_t batch_samples = 0;
    // The process metrics of each device ([outputs.mqtt.metrics]).
    MetricSets metrics{};
  };

  EdgeSession(Ids ids, const std::array<double, 16>& deadband, Publisher& out);

  // A new MQTT session (up) with the bdSeq of its CONNECT's will, or the
  // session lost (up = false). Every call with up = true starts a new
  // Sparkplug session: births follow as soon as publishing is allowed.
  void set_link(bool up, std::uint8_t bd_seq, std::uint64_t now_ms);
  // The primary host's STATE (only with wait_for_primary).
  void set_primary_online(bool online, std::uint64_t now_ms);
  // NCMD Node Control/Rebirth = true.
  void rebirth(std::uint64_t now_ms);
  // The standby of a hot-standby pair is not the edge node: it neither
  // publishes (its link is down) nor stores what it would have published.
  void set_active(bool active) noexcept { active_ = active; }
  void on_device(const DeviceRecord& record, std::uint64_t now_ms);
  void on_sample(const cobridge_sample& sample, std::uint64_t now_ms);
  // Publishes the DDATA batched since the last flush(): one message per
  // device (more if it holds over PayloadBuilder::kMaxMetrics metrics), each
  // metric with its own frame's time. The publisher calls it after each pass
  // over its queue, so a lone sample waits for nothing and a burst that
  // queued while it published goes out in few messages.
  void flush();
  // A command's outcome or refusal as the device's DDATA; not sent (counted
  // as a drop) while the device is not born.
  void publish_result(const CommandResult& result, std::uint64_t now_ms);

  // The index of the known device whose Sparkplug device id is `id`, -1 if none.
  [[nodiscard]] int device_index_of(std::string_view id) const noexcept;
  // Its configured name ("" for an unknown index).
  [[nodiscard]] const char* device_name(std::uint16_t index) const noexcept;

  [[nodiscard]] bool live() const noexcept { return link_up_ && (!ids_.wait_for_primary || primary_online_); }
  [[nodiscard]] bool node_born() const noexcept { return node_born_; }
  [[nodiscard]] const SessionCounters& counters() const noexcept { return counters_; }

 private:
  static constexpr std::size_t kProcess = 16;
  enum class Heard : std::uint8_t { kUnknown, kOnline, kOffline };

  struct Device {
    bool known = false;
    bool born = false;
    Heard heard = Heard::kUnknown;
    DeviceRecord info;
    std::string device_id;
    std::string dbirth, ddata, ddeath;  // topics
    std::array<Scalar, kProcess> last{};
    std::array<std::uint64_t, kProcess> last_ms{};
    std::array<bool, kProcess> has_last{};
    std::array<Scalar, kProcess> sent{};
    std::array<bool, kProcess> has_sent{};
    HistoryBuffer history;
    HistoryBuffer batch;  // DDATA not yet flushed (Ids::batch_samples)
    std::uint32_t metrics = MetricSets::kAll;  // bit process_index(id): published (Ids::metrics)
  };

  // Whether process metric k (process_index) is in the device's metric set.
  [[nodiscard]] static bool in_metric_set(const Device& d, std::size_t k) noexcept { return (d.metrics >> k & 1u) != 0; }
  void update_liveness(std::uint64_t now_ms);
  void births(std::uint64_t now_ms);
  void publish_nbirth(std::uint64_t now_ms);
  void publish_dbirth(Device& d, std::uint64_t now_ms);
  void add_identity(const Device& d, std::uint64_t now_ms);
  void add_commands(const Device& d, std::uint64_t now_ms);
  void publish_ddeath(Device& d, std::uint64_t now_ms);
  void publish_ddata(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms);
  void track_status(Device& d, const cobridge_sample& s, std::uint64_t now_ms);
  void store(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms);
  std::size_t take_changed(Device& d, std::span<const Reading> readings, std::span<Reading, kProcess> out) noexcept;
  void queue_ddata(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms);
  void flush_device(Device& d);
  void publish_entries(Device& d, const HistoryBuffer& entries, bool historical, std::uint64_t payload_ms);
  void replay(Device& d, std::uint64_t now_ms);
  void flush_entries(Device& d);
  [[nodiscard]] bool worth_sending(const Device& d, const Reading& r) const noexcept;
  void send(const std::string& topic, bool birth);
  std::uint8_t next_seq() noexcept { return seq_++; }  // wraps 255 -> 0

  Ids ids_;
  std::array<double, 16> deadband_;
  Publisher& out_;
  PayloadBuilder builder_;
  std::vector<std::uint8_t> buffer_;
  std::vector<Device> devices_;
  std::string nbirth_topic_;
  bool link_up_ = false;
  bool primary_online_ = false;
  bool node_born_ = false;
  bool active_ = true;
  std::uint8_t bd_seq_ = 0;
  std::uint8_t seq_ = 0;
  std::size_t batched_devices_ = 0;  // devices whose batch is not empty
  SessionCounters counters_;
};

}  // namespace cobridge::mqtt
