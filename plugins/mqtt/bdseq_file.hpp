// BdSeqFile: the edge node's bdSeq kept across daemon restarts. Sparkplug
// 3.0 (6.4.x "bdSeq", tck-id-payloads-nbirth-bdseq-increment) has the bdSeq
// of each MQTT CONNECT's will one more (mod 256) than the previous
// CONNECT's, so that a host can tell the NDEATH of an old session from the
// one of the current; a restart that began at 0 again would let a late will
// of the previous run kill the new session in the host's eyes.
//
// The file holds the last bdSeq used, in decimal ("17\n"). next() writes the
// new value before it goes into a CONNECT: a temporary file beside it,
// fsync, rename over the old (atomic on POSIX file systems), fsync of the
// folder. A file that holds anything else is reported and set aside as
// "<path>.bad" (never overwritten without a log line); the count then
// starts at 0. An empty path keeps the count in memory only.
//
// Thread contract: the control thread (start) and libmosquitto's client
// thread (reconnect), never at once (the client thread is started after and
// joined before); a mutex guards it anyway. Off the hot path (disk I/O).
#pragma once

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

namespace cobridge::mqtt {

class BdSeqFile {
 public:
  using LogFn = std::function<void(int level, const std::string& msg)>;

  BdSeqFile(std::string path, LogFn log);

  // Reads the file: the last bdSeq used, or nothing (none yet, unreadable or damaged: logged).
  void load();
  // The bdSeq of the next CONNECT: the last + 1 (mod 256), or 0 when none;
  // with `at_least_after` (the bdSeq another gateway of the pair used last)
  // that one + 1 instead. Persisted before it is returned (a failed write is
  // logged; the value is used anyway).
  [[nodiscard]] std::uint8_t next(std::optional<std::uint8_t> at_least_after = std::nullopt);
  [[nodiscard]] std::optional<std::uint8_t> last() const;
  [[nodiscard]] const std::string& path() const noexcept { return path_; }

 private:
  void save(std::uint8_t value);

  std::string path_;
  LogFn log_;
  mutable std::mutex mutex_;
  std::optional<std::uint8_t> last_;
  bool write_failed_logged_ = false;
};

// The bdSeq a file's text holds ("0".."255", an optional newline); nothing otherwise.
[[nodiscard]] std::optional<std::uint8_t> parse_bdseq(const std::string& text) noexcept;

}  // namespace cobridge::mqtt
