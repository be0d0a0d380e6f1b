// What discovery knows about each node-ID of one bus: the identities the
// SDO 0x1018 probe found there, a clash it could not pair up, and whether the
// bus manager supervises the node. The identity probe writes it; node-ID
// assignment and commissioning read it.
//
// Thread: the bus's control thread, like the rest of discovery.
#pragma once

#include "canopen/lss.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cobridge::bus::discovery {

using canopen::LssAddress;

// Distinct answers to one probe request; a handful is all a bus can carry
// in one window, so a fixed array keeps the frame path allocation-free.
struct AnswerSet {
  std::array<std::uint32_t, 8> v{};
  std::uint8_t n = 0;
  bool overflow = false;
  void add(std::uint32_t x) noexcept {
    for (std::uint8_t i = 0; i < n; ++i)
      if (v[i] == x) return;
    if (n < v.size()) v[n++] = x;
    else overflow = true;
  }
  [[nodiscard]] bool contains(std::uint32_t x) const noexcept {
    for (std::uint8_t i = 0; i < n; ++i)
      if (v[i] == x) return true;
    return false;
  }
};
// The answers to 0x1018/1..4 (vendor, product, revision, serial).
using IdentityAnswers = std::array<AnswerSet, 4>;

struct NodePicture {
  std::vector<LssAddress> ids;  // from the last finished probe (single or fully known clash)
  IdentityAnswers seen;         // raw answers of the last finished probe
  bool clash = false;
  bool supervised = false;      // the bus manager supervises this node
  // Supervision was lost and no probe has looked since: `ids` may be stale.
  bool unsure = false;
  // Who was identified here last, kept when a probe finds nobody: while the
  // bus manager supervises this node (its heartbeat is fine) that device is
  // present, even if a probe during a silence found no one.
  std::vector<LssAddress> last;
};
// Indexed by node-ID; [0] is unused.
using BusPicture = std::array<NodePicture, 128>;

// One physical device: the revision may differ between what a probe and a
// scan report (several revisions are tried), the rest may not.
[[nodiscard]] inline bool same_device(const LssAddress& a, const LssAddress& b) noexcept {
  return a.vendor == b.vendor && a.product == b.product && a.serial == b.serial;
}

// "vendor 0x... product 0x... revision 0x... serial n", for event texts.
[[nodiscard]] std::string describe(const LssAddress& a);

}  // namespace cobridge::bus::discovery
