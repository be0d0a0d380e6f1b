// `cobridge watch`: a DDS subscriber for the gateway's three topics
// (EncoderSample, EncoderEvent, DeviceStatus; plugins/dds/cobridge.idl) that
// prints one line per sample: the live values of every encoder, EMCY events
// and device status changes, as text or as JSON lines.
//
// Reader QoS: EncoderSample best-effort keep-last 16 (matches a best-effort
// or reliable writer), EncoderEvent reliable keep-last 32, DeviceStatus
// reliable transient-local keep-last 1 (so the current state of every device
// is printed first). The network is Cyclone's (CYCLONEDDS_URI).
// Thread: the CLI's main thread; waits on a DDS waitset.
#pragma once

#include <cstdint>
#include <string>

namespace cobridge::cli {

struct WatchOptions {
  std::uint32_t domain = 0;
  std::string gateway;       // only this gateway id; empty = all
  std::string topic_prefix;  // as the plugin's topic_prefix
  bool json = false;
  std::uint64_t count = 0;   // exit after this many printed samples; 0 = run on
  double timeout_s = 0;      // give up after this long; 0 = never
  // Read EncoderSample reliably and keep every sample (for audits and tests;
  // the plugin's sample_reliability must be "reliable" too). Default: the
  // latest samples, best-effort, as a live display wants.
  bool reliable = false;
};

// Exit codes: 0 done (count reached, timeout without --count, or
// interrupted), 1 DDS error, 3 timeout before --count samples arrived.
int watch(const WatchOptions& options);

}  // namespace cobridge::cli
