// Fuzz target: the state store's reader and writer (daemon/bus/state_store.*,
// "a state file that cannot be read is kept, never
// overwritten"). The bytes are assignments.state in a fresh directory; the
// store loads it. Invariants (abort on violation), as state_store.hpp
// promises:
//   * a file that does not read is set aside: load() fails with
//     malformed_lines or read_failed, assignments.state is gone, exactly one
//     assignments.state.bad-* holds the input's bytes, the store holds
//     (hold() says why), a put() changes the memory and writes no file, and
//     a second store on the directory holds too (code held);
//   * the report is printable text with at most kProblemsNamed lines named:
//     the file's bytes never reach the log;
//   * a file loads only when every line reads (a blank or '#' line aside),
//     and gives the table its lines give, line by line
//     (parse_line; a later line for a device replaces it);
//   * a file that reads round-trips: the store saves it (a put and an erase
//     of a device on a bus of its own) and a second store loads the same
//     table, bus by bus.
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_dir.hpp"
#include "bus/state_store.hpp"

using namespace cobridge;
using bus::Assignment;
using bus::StateStore;
using bus::StateStoreErrc;

namespace {

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The table the file's lines give, parsed one by one: a later line for the
// same device replaces the earlier in its place, as put() would; `bad`
// counts the lines (not blank, not a comment) that do not read.
std::vector<Assignment> table_of(std::string_view text, std::size_t& bad) {
  bad = 0;
  std::vector<Assignment> out;
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos || line[first] == '#') continue;
    auto parsed = StateStore::parse_line(line);
    if (!parsed.ok()) {
      ++bad;
      continue;
    }
    const Assignment a = parsed.value();
    auto same = [&](const Assignment& b) {
      return b.bus == a.bus && b.vendor == a.vendor && b.product == a.product && b.serial == a.serial;
    };
    if (auto it = std::find_if(out.begin(), out.end(), same); it != out.end()) *it = a;
    else out.push_back(a);
  }
  return out;
}

std::vector<Assignment> on_bus(const std::vector<Assignment>& table, const std::string& bus) {
  std::vector<Assignment> out;
  for (const Assignment& a : table)
    if (a.bus == bus) out.push_back(a);
  return out;
}

void check_report(const Error& e) {
  std::size_t lines = 0;
  for (const char c : e.message) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') ++lines;
    else if (u < 0x20 || u >= 0x7F) std::abort();
  }
  // "N lines do not read:", kProblemsNamed lines, "N more", where the bytes are.
  if (lines > StateStore::kProblemsNamed + 3 || e.message.size() > 4096) std::abort();
}

void check_set_aside(const std::filesystem::path& dir, StateStore& store, const Error& e, std::string_view input) {
  if (e.code != make_error_code(StateStoreErrc::malformed_lines) &&
      e.code != make_error_code(StateStoreErrc::read_failed))
    std::abort();
  check_report(e);
  if (store.hold().empty() || std::filesystem::exists(store.path())) std::abort();
  std::size_t copies = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().filename().string().rfind("assignments.state.bad-", 0) != 0) std::abort();
    if (read_all(entry.path()) != input) std::abort();
    ++copies;
  }
  if (copies != 1) std::abort();
  const Assignment a{"fuzz-bus", 1, 2, 3, 4, 5, "print"};
  if (store.put(a) || !store.find("fuzz-bus", 2, 3, 1) || std::filesystem::exists(store.path())) std::abort();
  StateStore again(dir);
  if (again.load().code != make_error_code(StateStoreErrc::held) || again.hold().empty()) std::abort();
}

void check_round_trip(const std::filesystem::path& dir, StateStore& store, std::string_view input) {
  if (!store.hold().empty()) std::abort();
  std::size_t bad = 0;
  const std::vector<Assignment> table = table_of(input, bad);
  if (bad != 0) std::abort();  // a line that does not read makes the file one to set aside
  std::set<std::string> buses;
  for (const Assignment& a : table) buses.insert(a.bus);
  for (const std::string& bus : buses)
    if (store.on_bus(bus) != on_bus(table, bus)) std::abort();
  std::string probe = "fuzz-probe";
  while (buses.count(probe) != 0) probe += "-";
  if (store.put(Assignment{probe, 1, 2, 3, 4, 5, "print"}) || store.erase(probe, 2, 3, 1)) std::abort();
  StateStore again(dir);
  if (again.load() || !again.hold().empty() || !again.on_bus(probe).empty()) std::abort();
  for (const std::string& bus : buses)
    if (again.on_bus(bus) != on_bus(table, bus)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::filesystem::path dir = fuzz::fresh_dir("state");
  {
    std::ofstream file(dir / StateStore::kFileName, std::ios::binary);
    file.write(input.data(), static_cast<std::streamsize>(input.size()));
  }
  StateStore store(dir);
  const Error e = store.load();
  if (e) {
    check_set_aside(dir, store, e, input);
  } else {
    check_round_trip(dir, store, input);
  }
  std::filesystem::remove_all(dir);
  return 0;
}
