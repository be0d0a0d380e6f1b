// StateStore: the gateway's memory of node-ID assignments and applied
// configurations, kept in <state_dir>/assignments.state so that a restart
// needs no new scan and an unchanged device is not rewritten.
//
// One line per device: bus, serial, vendor, product, revision, node-ID,
// configuration fingerprint, as `key=value` fields separated by blanks
// (values percent-encoded where they hold blanks, '%', '=' or '#'); '#'
// starts a comment line. Written atomically (temp file + fsync + rename +
// fsync of the directory), so a crash leaves the old or the new file, never a
// torn one.
//
// A file that cannot be read (a line that does not read, binary garbage,
// more than kMaxFileBytes, an I/O error, a symbolic link) is never written
// over: it is set aside as assignments.state.bad-<UTC time>
// (sys/set_aside.hpp) and the store *holds*: it starts empty, and node-IDs
// must not be assigned (the bus managers commission nothing and say why in
// their status) until an operator decides, because a gateway that forgot
// which serial had which node-ID would hand them out again differently.
// While a set-aside copy is in the directory and no state file is, the store
// holds too, so a restart does not take the missing file for a fresh start.
// The operator's decision is a state file that reads: the repaired or a
// restored file, or an empty one to start without the memory, then a reload
// (docs/operations.md, "A state file that cannot be read"). While it holds,
// put() and erase() change the memory only; the file is not written.
//
// Where the file is written: by default inside put()/erase(), before they
// return (tools and tests). start_writer() moves the writes to a thread of
// their own (the daemon does): put()/erase() then change the table in
// memory, which every reader sees at once, and wake the writer, which
// writes the latest table (several changes coalesce into one write). A bus's
// control thread then never waits for the disk: the two fsyncs of a write
// took over 150 ms on a busy disk, longer than a standby waits for the
// master's heartbeat (canopen/master_election.hpp), and an LSS step's answer window is
// milliseconds. A write that fails is logged once per run of failures and
// tried again a second later with the table as it is then; stop_writer()
// (and the destructor) writes what is pending, then joins.
//
// Thread: shared by the bus managers; every call takes an internal mutex.
// File I/O happens inside load() (the start, the main thread's reload) and,
// without the writer thread, inside put()/erase(): control threads only,
// never the hot path.
#pragma once

#include "base/result.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <vector>

namespace cobridge::bus {

struct Assignment {
  std::string bus;
  std::uint32_t serial = 0;
  std::uint32_t vendor = 0;
  std::uint32_t product = 0;
  std::uint32_t revision = 0;
  std::uint8_t node_id = 0;
  std::string fingerprint;  // empty = never configured

  friend bool operator==(const Assignment&, const Assignment&) = default;
};

enum class StateStoreErrc {
  malformed_lines = 1,  // load(): lines that do not read: the file was set aside, the store holds
  read_failed,          // load(): the file exists but cannot be read: set aside, the store holds
  invalid_assignment,   // put(): empty bus name or node-ID outside 0..127
  held,                 // load(): no state file, but a set-aside copy waits for an operator
};
[[nodiscard]] const std::error_category& state_store_category() noexcept;
[[nodiscard]] std::error_code make_error_code(StateStoreErrc e) noexcept;

class StateStore {
 public:
  static constexpr const char* kFileName = "assignments.state";
  // Far beyond 127 node-IDs on any number of buses (about 150 bytes a line).
  static constexpr std::uint64_t kMaxFileBytes = 4u << 20;
  // The problems load() names (file:line: why) before it counts the rest.
  static constexpr std::size_t kProblemsNamed = 5;

  // How the file is written (sys::write_file_atomically; a test's stand-in).
  using FileWriter = std::function<Error(const std::filesystem::path&, const std::string&)>;
  static constexpr std::chrono::milliseconds kRetryDelay{1000};  // after a failed write (writer thread)

  explicit StateStore(std::filesystem::path dir, FileWriter writer = {});
  ~StateStore();
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  // Writes from now on happen on a thread of their own (see above).
  void start_writer();
  // Writes what is pending and joins the writer thread; nothing when none runs.
  void stop_writer();
  // Reads the file and replaces the memory with it. A missing file is an
  // empty store (it holds when a set-aside copy is there: kFailed, code
  // held). A file that cannot be read is set aside and the store holds:
  // kInvalidArgument with code malformed_lines (the first kProblemsNamed
  // lines that do not read as file:line: why, one per line, then how many
  // more), or kFailed with read_failed (why); where = the file, and the
  // message ends with where the bytes are now. A file that reads releases a
  // hold. The caller logs it; hold() gives the one-line text for status.
  // With the writer thread, load() waits for a write in progress, and a
  // write pending when the store starts to hold is dropped.
  [[nodiscard]] Error load();
  // Why node-IDs must not be assigned now, in one line for the log and
  // `cobridge status`; empty when they may be.
  [[nodiscard]] std::string hold() const;
  [[nodiscard]] std::optional<Assignment> find(const std::string& bus, std::uint32_t vendor,
                                               std::uint32_t product, std::uint32_t serial) const;
  [[nodiscard]] std::vector<Assignment> on_bus(const std::string& bus) const;
  // Inserts or replaces (same bus + identity) and writes the file (or has
  // the writer thread write it; not while the store holds). The directory is
  // created if missing. Writing nothing when the entry is unchanged spares the
  // disk on every reconfiguration.
  // A failure: kInvalidArgument (code invalid_assignment) for an empty bus
  // name or a node-ID above 127, else (no writer thread) kFailed with the
  // errno; where = the file. The store is unchanged then. With the writer
  // thread a failed write is its to log and retry.
  Error put(const Assignment& a);
  Error erase(const std::string& bus, std::uint32_t vendor, std::uint32_t product, std::uint32_t serial);
  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

  // The text form of one line and its parser, exposed for tests.
  [[nodiscard]] static std::string format_line(const Assignment& a);
  // The assignment of one line, or why it is refused (kInvalidArgument).
  [[nodiscard]] static Result<Assignment> parse_line(std::string_view line);

 private:
  [[nodiscard]] std::string text_locked() const;
  // Writes the file now, or wakes the writer thread; the mutex is held.
  Error save_locked();
  // The file cannot be used (`problem`): set aside, memory emptied, held.
  Error set_aside_and_hold(Error problem);
  Error load_missing();
  void run_writer();

  std::filesystem::path dir_;
  std::filesystem::path path_;
  FileWriter write_;
  mutable std::mutex mutex_;
  std::vector<Assignment> items_;
  std::string hold_;  // why nothing may be assigned; empty: not held
  // The writer thread (start_writer): what mutex_ guards, and the thread.
  std::condition_variable wake_;
  bool writer_on_ = false;
  bool unsaved_ = false;  // the table changed since the writer last took it
  bool stop_ = false;
  std::thread writer_;
  // Held by the writer thread while it writes and by load() while it reads
  // or sets the file aside: a write never lands on a file being set aside.
  // Order: file_mutex_ before mutex_.
  std::mutex file_mutex_;
};

}  // namespace cobridge::bus

template <>
struct std::is_error_code_enum<cobridge::bus::StateStoreErrc> : std::true_type {};
