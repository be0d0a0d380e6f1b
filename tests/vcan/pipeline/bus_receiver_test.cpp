// BusReceiver on real SocketCAN: TPDOs sent on vcan0 arrive as samples with
// kernel receive timestamps and contiguous sequence numbers; what the
// kernel filter excludes (SDO) never reaches the hot path, unless the bus has
// a flight recorder, whose recording then holds every frame.
#include "pipeline/bus_receiver.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <ctime>
#include <mutex>
#include <thread>
#include <vector>

#include "can/frame_recorder.hpp"

using namespace cobridge;
using namespace cobridge::pipeline;

namespace {

class Collect : public SampleSink {
 public:
  void deliver(std::span<const Sample> batch) noexcept override {
    std::lock_guard lock(m);
    samples.insert(samples.end(), batch.begin(), batch.end());
  }
  std::size_t size() {
    std::lock_guard lock(m);
    return samples.size();
  }
  std::mutex m;
  std::vector<Sample> samples;
};

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

}  // namespace

TEST(BusReceiverVcan, TpdosBecomeTimestampedSamplesWithoutLoss) {
  DeviceTable table;
  DecodePlan p;
  p.active = true;
  p.indexed = true;
  p.node_id = 10;
  p.device_index = 3;
  std::vector<MappedObject> map = {{0x60040020, true}, {0x60300110, true}};
  const cobridge::Error err = build_pdo_decode(map, p.tpdo[0]);
  ASSERT_TRUE(err.ok()) << err.message;
  table.publish(p);

  Collect sink;
  Dispatcher dispatcher(sink);
  BusReceiver rx(BusReceiverOptions{.bus_index = 1, .interface = "vcan0"}, table, dispatcher);
  dispatcher.add_source(rx.ring());
  dispatcher.start();
  const Error started = rx.start();
  ASSERT_FALSE(started) << started.to_string();

  can::SocketCanChannel tx(can::SocketCanConfig{.interface = "vcan0"});
  ASSERT_FALSE(tx.open()) << "vcan0 must exist (run inside tests/vcan/run-in-vcan)";
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const std::int64_t t_start = now_ns();
  constexpr int kFrames = 5000;
  int sent = 0;
  for (int i = 0; i < kFrames; ++i) {
    can::Frame f = can::Frame::make(0x18A, {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i >> 8), 0, 0, 0x10, 0x00});
    if (tx.send(f)) ++sent;
    // An SDO response on the same bus: the hot-path filter must keep it out.
    if (i % 100 == 0) (void)tx.send(can::Frame::make8(0x58A, {0x43, 0x04, 0x60, 0, 1, 2, 3, 4}));
    // UML is one slow CPU: give the RX thread a turn every 50 frames (~1 ms TPDO
    // rates on several buses, not an unbounded burst).
    if (i % 50 == 49) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (sink.size() + rx.stats().kernel_drops + rx.stats().ring_drops < static_cast<std::size_t>(sent) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  rx.stop();
  dispatcher.stop();

  const auto st = rx.stats();
  std::printf("sent %d, samples %zu, kernel drops %llu, ring drops %llu, ignored %llu\n", sent, sink.samples.size(),
              static_cast<unsigned long long>(st.kernel_drops), static_cast<unsigned long long>(st.ring_drops),
              static_cast<unsigned long long>(st.decoder.ignored));
  EXPECT_EQ(sent, kFrames);
  ASSERT_EQ(sink.samples.size() + st.kernel_drops + st.ring_drops, static_cast<std::size_t>(sent))
      << "every frame is a sample or a counted drop";
  EXPECT_EQ(st.kernel_drops + st.ring_drops, 0u) << "paced at 50 frames/ms the receiver keeps up";
  EXPECT_EQ(st.decoder.ignored, 0u) << "SDO frames must be filtered by the kernel, not decoded";
  std::uint32_t expect_seq = 1;
  std::int64_t last_position = -1;
  for (std::size_t i = 0; i < sink.samples.size(); ++i) {
    const Sample& s = sink.samples[i];
    ASSERT_EQ(s.sequence, expect_seq++) << "sequence numbers are per sample and contiguous";
    ASSERT_GT(s.position, last_position) << "in order";
    last_position = s.position;
    ASSERT_EQ(s.speed, 16);
    ASSERT_EQ(s.bus_index, 1);
    ASSERT_EQ(s.device_index, 3);
    ASSERT_GE(static_cast<std::int64_t>(s.rx_timestamp_ns), t_start) << "kernel receive timestamp";
    ASSERT_GE(s.publish_timestamp_ns, s.rx_timestamp_ns);
  }
}

// The control thread's online/offline changes travel through the RX thread.
TEST(BusReceiverVcan, StatusFromControlThreadBecomesStatusSample) {
  DeviceTable table;
  DecodePlan p;
  p.active = true;
  p.indexed = true;
  p.node_id = 12;
  table.publish(p);
  Collect sink;
  Dispatcher dispatcher(sink);
  BusReceiver rx(BusReceiverOptions{.bus_index = 0, .interface = "vcan0"}, table, dispatcher);
  dispatcher.add_source(rx.ring());
  dispatcher.start();
  ASSERT_FALSE(rx.start());
  ASSERT_TRUE(rx.post_status(StatusEvent{12, false, COBRIDGE_NMT_OPERATIONAL, now_ns()}));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (sink.size() < 1 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  rx.stop();
  dispatcher.stop();
  ASSERT_EQ(sink.samples.size(), 1u);
  EXPECT_EQ(sink.samples[0].kind, COBRIDGE_SAMPLE_STATUS);
  EXPECT_EQ(sink.samples[0].online, 0);
  EXPECT_EQ(sink.samples[0].node_id, 12);
}

// With a flight recorder the RX socket passes every frame: an SDO request and
// its abort (CiA 301 §7.2.4.3.17), LSS (CiA 305) and NMT, sent by another
// socket of this host as the control thread's are, land in the recording
// with kernel timestamps, oldest first; they become no samples and count as
// neither unknown nodes nor bad lengths, only as ignored. The TPDO beside
// them is still a sample.
TEST(BusReceiverVcan, WithARecorderEveryFrameIsRecordedAndOnlySamplesArePublished) {
  DeviceTable table;
  DecodePlan p;
  p.active = true;
  p.indexed = true;
  p.node_id = 10;
  std::vector<MappedObject> map = {{0x60040020, true}};
  ASSERT_TRUE(build_pdo_decode(map, p.tpdo[0]).ok());
  table.publish(p);
  Collect sink;
  Dispatcher dispatcher(sink);
  can::FrameRecorder recorder(64);
  BusReceiver rx(BusReceiverOptions{.bus_index = 0, .interface = "vcan0", .recorder = &recorder}, table, dispatcher);
  dispatcher.add_source(rx.ring());
  dispatcher.start();
  ASSERT_FALSE(rx.start());
  can::SocketCanChannel tx(can::SocketCanConfig{.interface = "vcan0"});
  ASSERT_FALSE(tx.open());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const std::vector<can::Frame> sent = {
      can::Frame::make8(0x60A, {0x23, 0x00, 0x18, 0x05, 100, 0, 0, 0}),           // SDO download 0x1800/5
      can::Frame::make8(0x58A, {0x80, 0x00, 0x18, 0x05, 0x20, 0x00, 0x00, 0x08}),  // its abort 08000020
      can::Frame::make8(0x7E5, {0x11, 0x15, 0, 0, 0, 0, 0, 0}),                    // LSS configure node-ID 21
      can::Frame::make(0x000, {0x01, 0x0A}),                                       // NMT start node 10
      can::Frame::make(0x18A, {1, 2, 3, 4}),                                       // TPDO1: a sample
  };
  for (const auto& f : sent) ASSERT_TRUE(tx.send(f));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((recorder.recorded() < sent.size() || sink.size() < 1) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  rx.stop();
  dispatcher.stop();
  const can::RecorderWindow w = recorder.snapshot(0, INT64_MAX);
  ASSERT_EQ(w.frames.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(w.frames[i], sent[i]) << "frame " << i;
    EXPECT_GT(w.frames[i].timestamp_ns, 0) << "kernel receive time";
  }
  ASSERT_EQ(sink.samples.size(), 1u);
  EXPECT_EQ(sink.samples[0].kind, COBRIDGE_SAMPLE_TPDO);
  const auto st = rx.stats();
  EXPECT_EQ(st.decoder.unknown_node, 0u);
  EXPECT_EQ(st.decoder.bad_length, 0u);
  EXPECT_EQ(st.decoder.ignored, 4u) << "SDO x2, LSS, NMT: dropped, not errors";
}
