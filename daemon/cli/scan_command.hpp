// `cobridge scan`: who is on this bus?
//
// 1. Listens for boot-up and heartbeat frames (0x700+node).
// 2. Probes every node-ID 1..127 with an SDO upload of 0x1018/1 at once and
//    reads 0x1018/2..4 of every node that answered. All answers within the
//    window are kept, so two devices on one node-ID (factory defaults) show
//    up as a clash instead of a garbled identity.
// 3. Runs LSS Fastscan for non-configured devices (node-ID FFh). Without
//    --assign-from it reports the first one found and leaves it alone; with
//    --assign-from N it gives each found device the next free node-ID from
//    N and stores it (CiA 305), until none is left.
#pragma once

#include <string>

namespace cobridge::cli {

struct ScanOptions {
  std::string iface;
  unsigned listen_ms = 300;
  unsigned sdo_timeout_ms = 100;
  unsigned lss_timeout_ms = 100;  // the longest a search step waits; learnt waits from 10 ms
  bool fastscan = true;
  unsigned assign_from = 0;   // 0 = do not assign
  std::string devices_dir;    // EDS directory for model names; empty = default
  bool json = false;
  std::string control = "/run/cobridge/control.sock";  // a daemon owning the bus answers from its discovery
};

int scan(const ScanOptions& o);

}  // namespace cobridge::cli
