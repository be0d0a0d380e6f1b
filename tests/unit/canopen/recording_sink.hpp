// RecordingSink: a can::FrameSink for protocol tests that keeps every frame a
// component sends, in order, so a test can compare them byte for byte; with
// `accept` false it refuses frames, as a full transmit queue does.
//
// Thread: the test's thread only.
#pragma once

#include <vector>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"

namespace cobridge::canopen::test {

class RecordingSink final : public can::FrameSink {
 public:
  bool send(const can::Frame& frame) noexcept override {
    if (!accept) return false;
    frames.push_back(frame);
    return true;
  }
  std::vector<can::Frame> frames;
  bool accept = true;
};

}  // namespace cobridge::canopen::test
