// FrameRecorder: the ring of the flight recorder (docs/operations.md,
// "Flight recorder"; docs/architecture.md, "Threads").
#include "can/frame_recorder.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

namespace cobridge::can {
namespace {

Frame at(std::int64_t ns, std::uint32_t id = 0x181, std::uint8_t byte = 0) {
  Frame f = Frame::make(id, {byte, 1, 2, 3});
  f.timestamp_ns = ns;
  return f;
}

TEST(FrameRecorder, CapacityCoversTheShortestFramesAtTheBitrate) {
  // 1 Mbit/s / 47 bits = 21277 frames/s (rounded up), 10 s of them.
  EXPECT_EQ(FrameRecorder::capacity_for(1000, 10), 212770u);
  EXPECT_EQ(FrameRecorder::capacity_for(125, 10), 26600u);
  EXPECT_EQ(FrameRecorder::capacity_for(125, 0), 1u);
  FrameRecorder r(FrameRecorder::capacity_for(1000, 10));
  // A slot is the frame, 24 bytes; one slot more than the capacity (the
  // one being written).
  EXPECT_EQ(r.memory_bytes(), 212771u * 24u);
  EXPECT_EQ(FrameRecorder::bytes_for(r.capacity()), r.memory_bytes());
}

TEST(FrameRecorder, SnapshotReturnsTheWindowOldestFirst) {
  FrameRecorder r(100);
  for (int i = 0; i < 50; ++i) r.record(at(1000 + i * 10, 0x181, static_cast<std::uint8_t>(i)));
  const RecorderWindow w = r.snapshot(1100, 1200);  // frames 10..20, bounds included
  ASSERT_EQ(w.frames.size(), 11u);
  EXPECT_EQ(w.skipped, 0u);
  EXPECT_EQ(w.frames.front().timestamp_ns, 1100);
  EXPECT_EQ(w.frames.front().data[0], 10);
  EXPECT_EQ(w.frames.back().timestamp_ns, 1200);
  EXPECT_EQ(r.recorded(), 50u);
}

TEST(FrameRecorder, WrapAroundKeepsOnlyTheNewestCapacityFrames) {
  FrameRecorder r(16);
  for (int i = 0; i < 40; ++i) r.record(at(i, 0x700 + static_cast<std::uint32_t>(i % 8)));
  const RecorderWindow w = r.snapshot(0, 1000);
  ASSERT_EQ(w.frames.size(), 16u);
  for (std::size_t i = 0; i < w.frames.size(); ++i) EXPECT_EQ(w.frames[i].timestamp_ns, 24 + static_cast<int>(i));
  EXPECT_EQ(r.recorded(), 40u);
}

TEST(FrameRecorder, EmptyRecorderGivesAnEmptyWindow) {
  FrameRecorder r(8);
  EXPECT_TRUE(r.snapshot(0, 1'000'000).frames.empty());
}

TEST(FrameRecorder, FramesKeepIdFlagsAndData) {
  FrameRecorder r(4);
  Frame f = Frame::make8(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8});
  f.flags = Frame::kFlagExtended;
  f.timestamp_ns = 5;
  r.record(f);
  const RecorderWindow w = r.snapshot(5, 5);
  ASSERT_EQ(w.frames.size(), 1u);
  EXPECT_EQ(w.frames[0], f);
  EXPECT_TRUE(w.frames[0].is_extended());
}

// The RX thread records whole receive batches: a batch that runs over the
// ring's end wraps, and the newest `capacity` frames come back in order.
TEST(FrameRecorder, BatchesWrapAroundTheRingEnd) {
  FrameRecorder r(10);  // 11 slots
  std::vector<Frame> batch(4);
  for (int b = 0; b < 7; ++b) {
    for (int i = 0; i < 4; ++i) batch[static_cast<std::size_t>(i)] = at(b * 4 + i, 0x181, static_cast<std::uint8_t>(b * 4 + i));
    r.record(batch);
  }
  EXPECT_EQ(r.recorded(), 28u);
  const RecorderWindow w = r.snapshot(0, 1000);
  ASSERT_EQ(w.frames.size(), 10u);
  for (std::size_t i = 0; i < w.frames.size(); ++i) {
    EXPECT_EQ(w.frames[i].timestamp_ns, 18 + static_cast<int>(i));
    EXPECT_EQ(w.frames[i].data[0], 18 + i);
  }
}

// One frame whose payload is derived from its number i (its timestamp).
Frame numbered(std::int64_t i) {
  Frame f = at(i, static_cast<std::uint32_t>(i & 0x7FF), static_cast<std::uint8_t>(i));
  f.data[1] = static_cast<std::uint8_t>(i >> 8);
  f.data[7] = static_cast<std::uint8_t>(~i);
  return f;
}

// A reader copies windows while the writer overwrites the ring at full
// speed, in batches of 1 to 7 frames: every frame returned is whole (its
// payload matches its timestamp) and in order; overwritten slots are
// skipped, not returned torn.
TEST(FrameRecorder, ConcurrentWriterAndReaderNeverSeeTornFrames) {
  FrameRecorder r(256);
  std::atomic<bool> stop{false};
  std::atomic<std::int64_t> last_written{0};
  std::thread writer([&] {
    Frame batch[7];
    for (std::int64_t i = 1; !stop.load(std::memory_order_relaxed) || i < 100'000;) {
      const auto n = static_cast<std::size_t>(1 + i % 7);
      for (std::size_t k = 0; k < n; ++k) batch[k] = numbered(i + static_cast<std::int64_t>(k));
      r.record(std::span<const Frame>(batch, n));
      i += static_cast<std::int64_t>(n);
      last_written.store(i - 1, std::memory_order_relaxed);
      // Now and then a pause, so that the reader also finishes windows
      // between laps (the real writer is bounded by the bus: 21277 frames/s).
      if (i % 64 < 7) std::this_thread::yield();
    }
  });
  while (last_written.load() < 1000) std::this_thread::yield();
  std::size_t frames = 0;
  for (int window = 0; window < 300; ++window) {
    const RecorderWindow w = r.snapshot(0, INT64_MAX);
    std::int64_t last = 0;
    for (const Frame& f : w.frames) {
      ASSERT_GT(f.timestamp_ns, last);
      last = f.timestamp_ns;
      ASSERT_EQ(f.id, static_cast<std::uint32_t>(f.timestamp_ns & 0x7FF));
      ASSERT_EQ(f.data[0], static_cast<std::uint8_t>(f.timestamp_ns));
      ASSERT_EQ(f.data[1], static_cast<std::uint8_t>(f.timestamp_ns >> 8));
      ASSERT_EQ(f.data[7], static_cast<std::uint8_t>(~f.timestamp_ns));
    }
    ASSERT_LE(w.frames.size() + w.skipped, 256u);
    frames += w.frames.size();
  }
  stop.store(true);
  writer.join();
  EXPECT_GT(frames, 0u);
  const RecorderWindow last = r.snapshot(0, INT64_MAX);
  ASSERT_EQ(last.frames.size(), 256u);
  EXPECT_EQ(last.frames.back().timestamp_ns, last_written.load());
}

}  // namespace
}  // namespace cobridge::can
