// CiA 301 predefined connection set (11-bit COB-IDs) and CiA 305 LSS COB-IDs.
// All three seed manuals use exactly these (J§1.2.2, F§6, E§3.1).
#pragma once

#include <cstdint>

namespace cobridge::canopen::cob {

inline constexpr uint32_t kNmt = 0x000;
inline constexpr uint32_t kSync = 0x080;
inline constexpr uint32_t kEmcyBase = 0x080;      // + node-ID
inline constexpr uint32_t kTpdo1Base = 0x180;     // + node-ID
inline constexpr uint32_t kRpdo1Base = 0x200;
inline constexpr uint32_t kTpdo2Base = 0x280;
inline constexpr uint32_t kRpdo2Base = 0x300;
inline constexpr uint32_t kTpdo3Base = 0x380;
inline constexpr uint32_t kTpdo4Base = 0x480;
inline constexpr uint32_t kSdoTxBase = 0x580;     // server -> client, + node-ID
inline constexpr uint32_t kSdoRxBase = 0x600;     // client -> server, + node-ID
inline constexpr uint32_t kNmtErrorControlBase = 0x700;  // boot-up, heartbeat, guarding
inline constexpr uint32_t kLssSlaveToMaster = 0x7E4;
inline constexpr uint32_t kLssMasterToSlave = 0x7E5;

// Node-IDs: 1..127 valid; 0xFF is "not configured" in LSS (CiA 305).
inline constexpr uint8_t kNodeIdMin = 1;
inline constexpr uint8_t kNodeIdMax = 127;
inline constexpr uint8_t kNodeIdUnconfigured = 0xFF;

[[nodiscard]] constexpr bool valid_node_id(unsigned id) noexcept {
  return id >= kNodeIdMin && id <= kNodeIdMax;
}

}  // namespace cobridge::canopen::cob
