// Identity probe: who is at which node-ID, by SDO upload of the CiA 301
// identity object 0x1018/1..4 (vendor, product, revision, serial).
//
// A device already on a node-ID shows itself by its boot-up (0x700+id `00`),
// its heartbeat, or by answering this probe. Probes run: all node-IDs 1..127
// at start(), then every `discovery_period_s` for the node-IDs the bus
// manager does not supervise (set_supervised), at once for a node whose
// supervision is turned off (heartbeat lost: is the device still there?),
// and on every boot-up (which re-identifies a restarted device, so a swapped
// part never silently inherits the old one's settings). The probe is raw SDO upload
// frames sent to many node-IDs at once (one sub-index per sub-round; only the
// nodes that answered go on to the next), so that several answers to one
// request are seen: two different answers = two devices on one node-ID (a
// clash). Two boot-ups from one node-ID within `bootup_clash_window` are a
// clash too, unless discovery caused them (a reset it sent) or the second
// came in place of the answer to a request (the asked device rebooted). A round ends
// `probe_settle` after the last answer once every addressed node answered (a
// second device's answer must have a chance to arrive), at the latest after
// the SDO timeout. What a finished round found goes into the BusPicture and
// comes out as one ProbeResult per node for the commissioning to act on.
//
// Why not SdoClient: it serves one server and takes the first answer; the
// probe addresses up to 127 nodes at once and must see every answer.
//
// Thread: the bus's control thread. on_*frame() do not allocate.
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "bus/discovery.hpp"
#include "bus/discovery/bus_picture.hpp"

#include <bitset>
#include <cstdint>
#include <vector>

namespace cobridge::bus::discovery {

// What the probe of one node found, once its round is over.
struct ProbeResult {
  enum class Kind : std::uint8_t {
    nobody,      // no answer: a device that was here is absent now
    refused,     // an SDO abort: someone is there, who is unknown
    incomplete,  // stopped answering half-way (reset, lost answers): asked again
    identified,  // one device (picture.ids[0])
    clash,       // several devices (picture.seen; ids when they pair up)
  };
  Kind kind = Kind::nobody;
  std::uint8_t node = 0;
  bool bootup = false;       // the probe followed a boot-up
  bool was_known = false;    // nobody: a device or a clash had been seen here
  bool changed = false;      // the presence picture changed (decide the unknown devices again)
  bool full = false;         // of a start-up or periodic round
  std::uint32_t count = 0;   // clash: devices seen (a lower bound)
  bool first_report = false; // clash: not reported since the node last held one device or none
};

// Told while the round is still running (decisions then know that later
// nodes may show a device yet).
class ProbeListener {
 public:
  virtual void on_probed(const ProbeResult& r) = 0;
  virtual void on_round_end(bool full, canopen::Duration took) = 0;

 protected:
  ~ProbeListener() = default;
};

class IdentityProbe {
 public:
  IdentityProbe(can::FrameSink& sink, const DiscoveryOptions& options) : sink_(sink), opt_(options) {}

  void set_sdo_timeout(canopen::Duration t) noexcept { sdo_timeout_ = t; }
  // The bus's `discovery`: off, nothing is ever probed (boot-ups are still seen).
  void set_enabled(bool on) noexcept { enabled_ = on; }

  // 0x580+n answers to the running round; true when used.
  bool on_sdo_answer(const can::Frame& f, canopen::TimePoint now) noexcept;
  // 0x700+n boot-ups. `may_clash`: discovery has reset nobody lately (a
  // reset it sent may bring two boot-ups from one node-ID: no clash).
  void on_error_control(const can::Frame& f, canopen::TimePoint now, bool may_clash) noexcept;
  // Nodes that sent a boot-up since the last call.
  [[nodiscard]] std::bitset<128> take_bootups() noexcept;

  // Probe node `n` at the next round. `bootup`: the probe follows a boot-up.
  void want(std::uint8_t n, bool bootup = false) noexcept;
  // The same for a decision that waits for node `n`; nothing when `n` is in
  // the running round (its end decides again).
  void request(std::uint8_t n) noexcept;
  [[nodiscard]] bool requested() const noexcept { return want_.any(); }

  // Starts a round of the requested nodes and `also`. `full`: the start-up
  // or periodic probe (which decides swaps and looks for FFh afterwards).
  // `window`: the round ends this long after its requests at the latest
  // (zero: the SDO timeout), for nodes expected to answer at once.
  void begin(canopen::TimePoint now, bool full, const std::bitset<128>& also = {},
             canopen::Duration window = {});
  // Sends, collects and finishes sub-rounds, telling `l` of each finished
  // node and of the round's end. Returns true when a sub-round or the round
  // ended.
  bool drive(canopen::TimePoint now, ProbeListener& l);
  [[nodiscard]] bool active() const noexcept { return round_.active; }
  [[nodiscard]] canopen::TimePoint next_deadline(canopen::TimePoint now) const noexcept;

  [[nodiscard]] const BusPicture& picture() const noexcept { return picture_; }
  [[nodiscard]] NodePicture& node(std::uint8_t n) noexcept { return picture_[n]; }
  // Where device `a` is, as far as the probes know.
  [[nodiscard]] std::optional<std::uint8_t> present_at(const LssAddress& a) const;

 private:
  struct NodeState {
    IdentityAnswers vals;  // answers of the running probe
    bool aborted = false;  // 0x1018 answered with an abort
    bool clash_reported = false;
    canopen::TimePoint last_bootup = canopen::TimePoint::min();
    bool bootup_clash = false;
  };
  struct Round {
    bool active = false;
    bool full = false;
    std::uint8_t sub = 1;
    std::vector<std::uint8_t> members;
    std::bitset<128> in;
    std::bitset<128> answered;
    std::bitset<128> bootup;
    std::size_t to_send = 0;  // members not yet sent this sub-round
    canopen::TimePoint deadline = canopen::kNever;
    canopen::Duration window{};  // how long silence is waited for (zero: the SDO timeout)
    canopen::TimePoint last_answer{};
    canopen::TimePoint started{};
  };

  void begin_sub(canopen::TimePoint now);
  void send_frames(canopen::TimePoint now);
  [[nodiscard]] bool all_answered() const noexcept;
  ProbeResult finish_node(std::uint8_t n);
  void take_identity(std::uint8_t n, const LssAddress& a, ProbeResult& r);
  void take_clash(std::uint8_t n, ProbeResult& r);

  can::FrameSink& sink_;
  DiscoveryOptions opt_;
  canopen::Duration sdo_timeout_{};
  bool enabled_ = true;
  BusPicture picture_{};
  std::array<NodeState, 128> state_{};
  std::bitset<128> want_;
  std::bitset<128> want_bootup_;
  std::bitset<128> bootups_;
  Round round_;
};

}  // namespace cobridge::bus::discovery
