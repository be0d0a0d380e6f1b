#include "bus/state_store.hpp"

#include "base/field_text.hpp"
#include "base/number_text.hpp"
#include "sys/atomic_file.hpp"
#include "sys/guarded_file.hpp"
#include "sys/logging.hpp"
#include "sys/set_aside.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>

namespace cobridge::bus {

namespace {

class StateStoreCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "state_store"; }
  std::string message(int ev) const override {
    switch (static_cast<StateStoreErrc>(ev)) {
      case StateStoreErrc::malformed_lines: return "state file has lines that do not read (set aside)";
      case StateStoreErrc::read_failed: return "state file cannot be read (set aside)";
      case StateStoreErrc::invalid_assignment: return "invalid assignment (empty bus or node-ID > 127)";
      case StateStoreErrc::held: return "state file missing while a set-aside copy waits for an operator";
    }
    return "unknown state store error";
  }
};

// A line parse_line refuses; load() adds the file and line.
Error refused(std::string why) { return Error(Errc::kInvalidArgument, std::move(why)); }

// The fields of a line, one bit each in the set of those seen.
enum StateField : unsigned {
  kFieldBus = 1,
  kFieldSerial = 2,
  kFieldVendor = 4,
  kFieldProduct = 8,
  kFieldRevision = 16,
  kFieldNode = 32,
  kFieldPrint = 64
};
constexpr unsigned kRequiredFields = kFieldBus | kFieldSerial | kFieldVendor | kFieldProduct | kFieldRevision | kFieldNode;
constexpr unsigned kNumericFields = kFieldSerial | kFieldVendor | kFieldProduct | kFieldRevision | kFieldNode;
constexpr std::pair<std::string_view, unsigned> kFieldNames[] = {
    {"bus", kFieldBus},           {"serial", kFieldSerial}, {"vendor", kFieldVendor},      {"product", kFieldProduct},
    {"revision", kFieldRevision}, {"node", kFieldNode},     {"fingerprint", kFieldPrint},
};

// The field named `key`; 0 for one this gateway does not know.
unsigned field_of(std::string_view key) noexcept {
  for (const auto& [name, field] : kFieldNames)
    if (name == key) return field;
  return 0;
}

std::string missing_fields(unsigned seen) {
  std::string names;
  for (const auto& [name, field] : kFieldNames)
    if ((kRequiredFields & field) != 0 && (seen & field) == 0) names += " " + std::string(name);
  return names;
}

// Stores the unescaped value of a known field in `out`, or says why it is
// refused.
Error store_field(unsigned field, std::string_view key, const std::string& value, Assignment& out) {
  std::uint64_t wide = 0;
  if ((field & kNumericFields) != 0 && !parse_unsigned(value, 0xFFFFFFFFU, wide)) {
    return refused("'" + std::string(key) + "' wants a number (decimal or 0x hex), got '" + value + "'");
  }
  const auto number = static_cast<std::uint32_t>(wide);
  switch (field) {
    case kFieldBus: out.bus = value; break;
    case kFieldSerial: out.serial = number; break;
    case kFieldVendor: out.vendor = number; break;
    case kFieldProduct: out.product = number; break;
    case kFieldRevision: out.revision = number; break;
    case kFieldPrint: out.fingerprint = value; break;
    case kFieldNode:
      if (number > 127) {
        return refused("node-ID " + std::to_string(number) + " outside 0..127");
      }
      out.node_id = static_cast<std::uint8_t>(number);
      break;
    default: break;
  }
  return {};
}

bool same_key(const Assignment& a, const std::string& bus, std::uint32_t vendor, std::uint32_t product,
              std::uint32_t serial) noexcept {
  return a.bus == bus && a.vendor == vendor && a.product == product && a.serial == serial;
}

// Where the operator's decision is described, named by every hold.
constexpr const char* kDecision = "docs/operations.md, \"A state file that cannot be read\"";

// A later line for the same device wins, as put() would have done.
void take(std::vector<Assignment>& loaded, Assignment a) {
  for (auto& existing : loaded) {
    if (same_key(existing, a.bus, a.vendor, a.product, a.serial)) {
      existing = std::move(a);
      return;
    }
  }
  loaded.push_back(std::move(a));
}

// The assignments of `text` into `loaded`; returns how many lines do not
// read, the first StateStore::kProblemsNamed of them in `problems` as
// "file:line: why" lines (why cut short: the file's bytes stay out of the log).
std::size_t parse_text(std::string_view text, const std::string& file, std::vector<Assignment>& loaded,
                       std::string& problems) {
  std::size_t bad = 0;
  std::uint32_t number = 0;
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos || line[first] == '#') continue;
    Result<Assignment> parsed = StateStore::parse_line(line);
    if (parsed.ok()) {
      take(loaded, std::move(parsed).value());
      continue;
    }
    if (++bad <= StateStore::kProblemsNamed)
      problems += file + ":" + std::to_string(number) + ": " + log_excerpt(parsed.error().message, 120) + "\n";
  }
  if (bad > StateStore::kProblemsNamed) problems += std::to_string(bad - StateStore::kProblemsNamed) + " more\n";
  return bad;
}

}  // namespace

const std::error_category& state_store_category() noexcept {
  static const StateStoreCategory category;
  return category;
}

std::error_code make_error_code(StateStoreErrc e) noexcept { return {static_cast<int>(e), state_store_category()}; }

StateStore::StateStore(std::filesystem::path dir, FileWriter writer)
    : dir_(std::move(dir)), path_(dir_ / kFileName), write_(std::move(writer)) {
  if (!write_) write_ = sys::write_file_atomically;
}

StateStore::~StateStore() { stop_writer(); }

void StateStore::start_writer() {
  const std::lock_guard lock(mutex_);
  if (writer_on_) return;
  writer_on_ = true;
  stop_ = false;
  writer_ = std::thread([this] { run_writer(); });
}

void StateStore::stop_writer() {
  {
    const std::lock_guard lock(mutex_);
    if (!writer_on_) return;
    stop_ = true;
  }
  wake_.notify_all();
  writer_.join();
  const std::lock_guard lock(mutex_);
  writer_on_ = false;
}

// The writer thread: the latest table, written outside the lock, so that
// put() and the readers never wait for the disk.
void StateStore::run_writer() {
  auto log = sys::logger("gateway");
  bool failing = false;
  bool tried_at_stop = false;
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return unsaved_ || stop_; });
    if (!unsaved_) return;  // stopping, nothing pending
    // load() may set the file aside meanwhile: it takes file_mutex_ first,
    // so the lock order is file_mutex_, then mutex_.
    lock.unlock();
    std::unique_lock file_lock(file_mutex_);
    lock.lock();
    if (!hold_.empty()) unsaved_ = false;  // holding: the file is the operator's
    if (!unsaved_) continue;
    const std::string text = text_locked();
    unsaved_ = false;
    lock.unlock();
    const Error e = write_(path_, text);
    file_lock.unlock();  // mutex_ is not held here, so the order stays file_mutex_ before mutex_
    lock.lock();
    if (!e) {
      if (failing) log->info("state file {} written again", path_.string());
      failing = false;
      continue;
    }
    if (!failing) log->error("state file {}; trying again every {} s", e.to_string(), kRetryDelay.count() / 1000);
    failing = true;
    unsaved_ = true;
    // Stopping: one more try at once (stop_writer() writes what is pending,
    // also when the stop came while a failing write was in the disk).
    if (stop_ && tried_at_stop) return;  // logged above
    tried_at_stop = stop_;
    if (stop_) continue;
    wake_.wait_for(lock, kRetryDelay, [this] { return stop_; });
  }
}

std::string StateStore::format_line(const Assignment& a) {
  std::string line = "bus=" + escape_field(a.bus);
  line += " serial=" + hex(a.serial);
  line += " vendor=" + hex(a.vendor);
  line += " product=" + hex(a.product);
  line += " revision=" + hex(a.revision);
  line += " node=" + std::to_string(unsigned{a.node_id});
  line += " fingerprint=" + escape_field(a.fingerprint);
  return line;
}

Result<Assignment> StateStore::parse_line(std::string_view line) {
  Assignment out;
  unsigned seen = 0;
  Result<Fields> fields = split_fields(line);
  if (!fields.ok()) return fields.error();
  for (const auto& [key, value] : *fields) {
    const unsigned field = field_of(key);
    if (field == 0) continue;  // a newer gateway may add fields; an older one keeps the line
    if (Error e = store_field(field, key, value, out)) return e;
    if ((seen & field) != 0) {
      return refused("'" + key + "' given twice");
    }
    seen |= field;
  }
  if ((seen & kRequiredFields) != kRequiredFields) {
    return refused("missing field(s):" + missing_fields(seen));
  }
  if (out.bus.empty()) {
    return refused("empty bus name");
  }
  return out;
}

Error StateStore::load() {
  const std::lock_guard file_lock(file_mutex_);  // no write of the writer thread meanwhile
  const Result<sys::FileText> file = sys::read_file_bounded(path_, kMaxFileBytes);
  if (!file.ok() && file.error().kind == Errc::kNotFound) return load_missing();
  if (!file.ok()) {
    return set_aside_and_hold(Error(Errc::kFailed, file.error().message, path_.string(),
                                    make_error_code(StateStoreErrc::read_failed)));
  }
  if (file->skipped != 0) {
    return set_aside_and_hold(Error(Errc::kFailed,
                                    "is " + std::to_string(file->size) + " bytes, more than the " +
                                        std::to_string(kMaxFileBytes) + " a state file may have",
                                    path_.string(), make_error_code(StateStoreErrc::read_failed)));
  }
  std::vector<Assignment> loaded;
  std::string problems;
  if (const std::size_t bad = parse_text(file->text, path_.string(), loaded, problems)) {
    problems.pop_back();
    return set_aside_and_hold(Error(Errc::kInvalidArgument,
                                    std::to_string(bad) + (bad == 1 ? " line does" : " lines do") + " not read:\n" +
                                        problems,
                                    path_.string(), make_error_code(StateStoreErrc::malformed_lines)));
  }
  const std::lock_guard lock(mutex_);
  items_ = std::move(loaded);
  hold_.clear();
  return {};
}

Error StateStore::load_missing() {
  const std::vector<std::filesystem::path> copies = sys::set_aside_copies(path_);
  const std::lock_guard lock(mutex_);
  items_.clear();
  if (copies.empty()) {
    hold_.clear();
    return {};
  }
  unsaved_ = false;
  const std::string decide = "no node-ID is assigned until an operator decides (" + std::string(kDecision) + ")";
  hold_ = "state file " + path_.string() + " is missing and " + copies.back().string() +
          " was set aside because it could not be read; " + decide;
  return Error(Errc::kFailed, "missing, and the set-aside copy " + copies.back().string() +
                                  " waits for an operator; " + decide,
               path_.string(), make_error_code(StateStoreErrc::held));
}

Error StateStore::set_aside_and_hold(Error problem) {
  const Result<std::filesystem::path> aside = sys::set_aside(path_, std::chrono::system_clock::now());
  const std::string now_where = aside.ok() ? "set aside as " + aside.value().string()
                                           : "left where it is and never written (" + aside.error().message + ")";
  const std::string decide = "no node-ID is assigned until an operator decides (" + std::string(kDecision) + ")";
  const std::string reason = problem.message.substr(0, problem.message.find(":\n"));
  problem.message += "\n" + now_where + "; " + decide;
  const std::lock_guard lock(mutex_);
  items_.clear();
  unsaved_ = false;
  hold_ = "state file " + path_.string() + " could not be read (" + reason + "); " + now_where + "; " + decide;
  return problem;
}

std::string StateStore::hold() const {
  const std::lock_guard lock(mutex_);
  return hold_;
}

std::optional<Assignment> StateStore::find(const std::string& bus, std::uint32_t vendor, std::uint32_t product,
                                           std::uint32_t serial) const {
  const std::lock_guard lock(mutex_);
  for (const auto& a : items_) {
    if (same_key(a, bus, vendor, product, serial)) return a;
  }
  return std::nullopt;
}

std::vector<Assignment> StateStore::on_bus(const std::string& bus) const {
  const std::lock_guard lock(mutex_);
  std::vector<Assignment> out;
  for (const auto& a : items_) {
    if (a.bus == bus) out.push_back(a);
  }
  return out;
}

Error StateStore::put(const Assignment& a) {
  if (a.bus.empty() || a.node_id > 127)
    return Error(Errc::kInvalidArgument,
                 "bus '" + a.bus + "' node-ID " + std::to_string(a.node_id) + " is not an assignment", path_.string(),
                 make_error_code(StateStoreErrc::invalid_assignment));
  const std::lock_guard lock(mutex_);
  for (auto& existing : items_) {
    if (same_key(existing, a.bus, a.vendor, a.product, a.serial)) {
      if (existing == a) return {};
      const Assignment before = existing;
      existing = a;
      Error e = save_locked();
      if (e) existing = before;
      return e;
    }
  }
  items_.push_back(a);
  Error e = save_locked();
  if (e) items_.pop_back();
  return e;
}

Error StateStore::erase(const std::string& bus, std::uint32_t vendor, std::uint32_t product, std::uint32_t serial) {
  const std::lock_guard lock(mutex_);
  for (auto it = items_.begin(); it != items_.end(); ++it) {
    if (same_key(*it, bus, vendor, product, serial)) {
      const Assignment before = *it;
      const auto pos = it - items_.begin();
      items_.erase(it);
      Error e = save_locked();
      if (e) items_.insert(items_.begin() + pos, before);
      return e;
    }
  }
  return {};
}

std::string StateStore::text_locked() const {
  std::string text = "# cobridge node-ID assignments and configuration fingerprints; written by cobridged\n";
  for (const auto& a : items_) {
    text += format_line(a);
    text += '\n';
  }
  return text;
}

Error StateStore::save_locked() {
  // Holding: the place of the file that could not be read stays empty
  // until the operator fills it (the memory alone has the change).
  if (!hold_.empty()) return {};
  if (writer_on_) {
    unsaved_ = true;
    wake_.notify_one();
    return {};
  }
  return write_(path_, text_locked());
}

}  // namespace cobridge::bus
