// can::FrameSink: where a protocol service puts the frames it wants sent.
//
// CANopen services never own a socket; they are handed a sink. The daemon
// passes a SocketCAN channel, unit tests a recorder or a virtual bus.
// Thread: called from the thread that drives the service; an implementation
// must not block (it queues or reports back-pressure through the result).
#pragma once

#include "can/frame.hpp"

namespace cobridge::can {

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  // Returns false when the frame could not be queued for sending (for example
  // the kernel transmit queue stayed full). The caller decides whether to retry.
  [[nodiscard]] virtual bool send(const Frame& frame) noexcept = 0;
};

}  // namespace cobridge::can
