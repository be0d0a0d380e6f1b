#include "cli/status_command.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace cobridge::cli {
namespace {

// The daemon's answers are JSON; the table view needs to read them back.
// A small parser for the whole grammar (RFC 8259) with a depth limit, so a
// malformed answer is reported rather than trusted.
struct Json {
  enum class Type { null, boolean, number, string, array, object };
  Type type = Type::null;
  bool boolean = false;
  double number = 0;
  std::string text;
  std::vector<Json> items;
  std::vector<std::pair<std::string, Json>> members;

  [[nodiscard]] const Json& operator[](std::string_view key) const {
    static const Json none;
    for (const auto& [k, v] : members)
      if (k == key) return v;
    return none;
  }
  [[nodiscard]] bool is_null() const noexcept { return type == Type::null; }
  [[nodiscard]] std::string str(std::string_view fallback = "-") const {
    if (type == Type::string) return text.empty() ? std::string(fallback) : text;
    if (type == Type::number) return std::to_string(static_cast<long long>(std::llround(number)));
    if (type == Type::boolean) return boolean ? "true" : "false";
    return std::string(fallback);
  }
  [[nodiscard]] long long integer() const noexcept { return type == Type::number ? std::llround(number) : 0; }
};

class JsonParser {
 public:
  explicit JsonParser(std::string_view text) : s_(text) {}

  std::optional<Json> parse(std::string& error) {
    Json v;
    if (!value(v, 0)) {
      error = error_ + " at byte " + std::to_string(pos_);
      return std::nullopt;
    }
    skip_ws();
    if (pos_ != s_.size()) {
      error = "trailing characters at byte " + std::to_string(pos_);
      return std::nullopt;
    }
    return v;
  }

 private:
  bool fail(const char* why) {
    error_ = why;
    return false;
  }
  void skip_ws() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\n' || s_[pos_] == '\r')) ++pos_;
  }
  bool literal(std::string_view word) {
    if (s_.substr(pos_, word.size()) != word) return fail("unexpected word");
    pos_ += word.size();
    return true;
  }
  bool value(Json& v, int depth) {
    if (depth > 64) return fail("nested too deeply");
    skip_ws();
    if (pos_ >= s_.size()) return fail("unexpected end");
    const char c = s_[pos_];
    if (c == '{') return object(v, depth);
    if (c == '[') return array(v, depth);
    if (c == '"') {
      v.type = Json::Type::string;
      return string(v.text);
    }
    if (c == 't' || c == 'f') {
      v.type = Json::Type::boolean;
      v.boolean = c == 't';
      return literal(c == 't' ? "true" : "false");
    }
    if (c == 'n') return literal("null");
    return number(v);
  }
  bool object(Json& v, int depth) {
    v.type = Json::Type::object;
    ++pos_;
    skip_ws();
    if (pos_ < s_.size() && s_[pos_] == '}') {
      ++pos_;
      return true;
    }
    while (true) {
      skip_ws();
      std::string key;
      if (pos_ >= s_.size() || s_[pos_] != '"') return fail("expected a member name");
      if (!string(key)) return false;
      skip_ws();
      if (pos_ >= s_.size() || s_[pos_] != ':') return fail("expected ':'");
      ++pos_;
      Json member;
      if (!value(member, depth + 1)) return false;
      v.members.emplace_back(std::move(key), std::move(member));
      skip_ws();
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < s_.size() && s_[pos_] == '}') {
        ++pos_;
        return true;
      }
      return fail("expected ',' or '}'");
    }
  }
  bool array(Json& v, int depth) {
    v.type = Json::Type::array;
    ++pos_;
    skip_ws();
    if (pos_ < s_.size() && s_[pos_] == ']') {
      ++pos_;
      return true;
    }
    while (true) {
      Json item;
      if (!value(item, depth + 1)) return false;
      v.items.push_back(std::move(item));
      skip_ws();
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < s_.size() && s_[pos_] == ']') {
        ++pos_;
        return true;
      }
      return fail("expected ',' or ']'");
    }
  }
  static void put_utf8(std::string& out, unsigned cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }
  bool string(std::string& out) {
    ++pos_;  // opening quote
    while (pos_ < s_.size()) {
      const char c = s_[pos_++];
      if (c == '"') return true;
      if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (pos_ >= s_.size()) break;
      const char e = s_[pos_++];
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          if (pos_ + 4 > s_.size()) return fail("short \\u escape");
          unsigned cp = 0;
          for (int i = 0; i < 4; ++i) {
            const char h = s_[pos_++];
            cp <<= 4;
            if (h >= '0' && h <= '9') cp |= static_cast<unsigned>(h - '0');
            else if (h >= 'a' && h <= 'f') cp |= static_cast<unsigned>(h - 'a' + 10);
            else if (h >= 'A' && h <= 'F') cp |= static_cast<unsigned>(h - 'A' + 10);
            else return fail("bad \\u escape");
          }
          put_utf8(out, cp);  // surrogate pairs are not needed for the daemon's texts
          break;
        }
        default: return fail("bad escape");
      }
    }
    return fail("unterminated string");
  }
  bool number(Json& v) {
    const std::size_t start = pos_;
    while (pos_ < s_.size() && std::strchr("+-0123456789.eE", s_[pos_]) != nullptr) ++pos_;
    if (start == pos_) return fail("unexpected character");
    const std::string text(s_.substr(start, pos_ - start));
    char* end = nullptr;
    v.number = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) return fail("bad number");
    v.type = Json::Type::number;
    return true;
  }

  std::string_view s_;
  std::size_t pos_ = 0;
  std::string error_;
};

// Sends one request line, returns the one answer line (without newline).
std::optional<std::string> request(const std::string& path, const std::string& line, int timeout_ms,
                                   std::string& error) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    error = "control socket path \"" + path + "\" is empty or too long";
    return std::nullopt;
  }
  path.copy(addr.sun_path, path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return std::nullopt;
  }
  timeval tv{timeout_ms / 1000, static_cast<suseconds_t>((timeout_ms % 1000) * 1000)};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    error = "cannot reach cobridged at " + path + ": " + std::strerror(err);
    if (err == ENOENT || err == ECONNREFUSED) error += " (is cobridged running? see --control)";
    if (err == EACCES) error += " (the socket is for the service's user and group)";
    return std::nullopt;
  }
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    error = std::string("sending the request: ") + std::strerror(errno);
    ::close(fd);
    return std::nullopt;
  }
  std::string answer;
  char buf[4096];
  while (answer.find('\n') == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n < 0) error = std::string("reading the answer: ") +
                         (errno == EAGAIN ? "no answer within " + std::to_string(timeout_ms) + " ms"
                                          : std::string(std::strerror(errno)));
      break;
    }
    answer.append(buf, static_cast<std::size_t>(n));
    if (answer.size() > (64u << 20)) {
      error = "answer larger than 64 MiB";
      break;
    }
  }
  ::close(fd);
  const auto nl = answer.find('\n');
  if (nl == std::string::npos) {
    if (error.empty()) error = "the daemon closed the connection without an answer";
    return std::nullopt;
  }
  answer.resize(nl);
  return answer;
}

// "2024-05-01T12:00:00.123Z" -> "2024-05-01 12:00:00Z"
std::string short_time(const Json& t) {
  if (t.type != Json::Type::string) return "-";
  std::string s = t.text;
  if (s.size() >= 19) {
    s[10] = ' ';
    s = s.substr(0, 19) + "Z";
  }
  return s;
}

std::string hex(long long v, int width) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llX", width, v);
  return buf;
}

void print_table(const Json& doc) {
  const auto& buses = doc["buses"].items;
  std::printf("cobridged %s on %s, pid %lld, %s, started %s, config %s\n", doc["version"].str().c_str(),
              doc["gateway"].str().c_str(), doc["pid"].integer(), doc["ready"].boolean ? "ready" : "starting",
              short_time(doc["started"]).c_str(), doc["config"].str().c_str());
  std::printf("%zu bus%s, %lld/%lld devices operational\n\n", buses.size(), buses.size() == 1 ? "" : "es",
              doc["devices_operational"].integer(), doc["devices_total"].integer());
  for (const auto& b : buses) {
    const auto& c = b["counters"];
    std::printf("bus %s (%s): %s%s%s; rx %lld, tx %lld, error frames %lld, rx drops %lld, reopens %lld\n",
                b["name"].str().c_str(), b["interface"].str().c_str(), b["open"].boolean ? "open" : "CLOSED",
                b["last_bus_event"].str("").empty() ? "" : ", last event: ",
                b["last_bus_event"].str("").c_str(), c["rx_frames"].integer(), c["tx_frames"].integer(),
                c["error_frames"].integer(), c["rx_overflow_drops"].integer(), c["reopens"].integer());
  }
  // Columns as wide as their widest cell: model names come from the EDS files.
  using Row = std::vector<std::string>;
  std::vector<Row> table{{"BUS", "NODE", "NAME", "MODEL", "SERIAL", "STATE", "ONLINE", "SINCE", "LAST EMCY"}};
  std::vector<std::string> errors{""};
  for (const auto& b : buses) {
    for (const auto& d : b["devices"].items) {
      const auto& emcy = d["last_emcy"];
      std::string last_emcy = "-";
      if (!emcy.is_null()) last_emcy = hex(emcy["code"].integer(), 4) + " " + emcy["text"].str("");
      table.push_back({b["name"].str(), d["node_id"].str(), d["name"].str(), d["model"].str(),
                       d["identity"]["serial"].str(), d["state"].str(), d["online"].boolean ? "yes" : "no",
                       short_time(d["since"]), last_emcy});
      errors.push_back(d["last_error"].str(""));
    }
  }
  std::vector<std::size_t> width(table.front().size(), 0);
  for (const auto& row : table)
    for (std::size_t i = 0; i < row.size(); ++i) width[i] = std::max(width[i], row[i].size());
  std::printf("\n");
  for (std::size_t r = 0; r < table.size(); ++r) {
    std::string line;
    for (std::size_t i = 0; i < table[r].size(); ++i) {
      line += table[r][i];
      if (i + 1 < table[r].size()) line += std::string(width[i] - table[r][i].size() + 2, ' ');
    }
    std::printf("%s\n", line.c_str());
    if (!errors[r].empty()) std::printf("    last error: %s\n", errors[r].c_str());
  }
  const std::size_t rows = table.size() - 1;
  if (rows == 0) std::printf("(no devices)\n");
  for (const auto& b : buses) {
    if (!b["problems"].items.empty()) {
      std::printf("\nproblems on %s:\n", b["name"].str().c_str());
      for (const auto& p : b["problems"].items) std::printf("  - %s\n", p.str().c_str());
    }
  }
  for (const auto& b : buses) {
    if (b["steps"].items.empty()) continue;
    std::printf("\nsteps on %s (most recent last):\n", b["name"].str().c_str());
    std::printf("  %-28s %-16s %10s  %s\n", "STEP", "DEVICE", "MS", "AT");
    for (const auto& s : b["steps"].items)
      std::printf("  %-28s %-16s %10.1f  %s\n", s["step"].str().c_str(), s["device"].str().c_str(),
                  s["ms"].number, short_time(s["at"]).c_str());
  }
}

}  // namespace

int status(const StatusOptions& o) {
  std::string error;
  const auto answer = request(o.control, "status", o.timeout_ms, error);
  if (!answer) {
    std::fprintf(stderr, "cobridge: status: %s\n", error.c_str());
    return 1;
  }
  const auto doc = JsonParser(*answer).parse(error);
  if (!doc || doc->type != Json::Type::object) {
    std::fprintf(stderr, "cobridge: status: the daemon's answer is not a JSON object: %s\n",
                 doc ? "wrong type" : error.c_str());
    return 1;
  }
  if (!(*doc)["error"].is_null()) {
    std::fprintf(stderr, "cobridge: status: the daemon refused: %s\n", (*doc)["error"].str().c_str());
    return 1;
  }
  if (o.json) {
    std::printf("%s\n", answer->c_str());
  } else {
    print_table(*doc);
  }
  return 0;
}

int commission(const CommissionOptions& o) {
  std::string error;
  const std::string line = o.bus.empty() ? "commission" : "commission " + o.bus;
  const auto answer = request(o.control, line, o.timeout_ms, error);
  if (!answer) {
    std::fprintf(stderr, "cobridge: commission: %s\n", error.c_str());
    return 1;
  }
  const auto doc = JsonParser(*answer).parse(error);
  if (!doc || doc->type != Json::Type::object) {
    std::fprintf(stderr, "cobridge: commission: the daemon's answer is not a JSON object: %s\n",
                 doc ? "wrong type" : error.c_str());
    return 1;
  }
  const bool ok = (*doc)["error"].is_null();
  if (o.json) {
    std::printf("%s\n", answer->c_str());
  } else if (ok) {
    std::string buses;
    for (const auto& b : (*doc)["buses"].items) buses += (buses.empty() ? "" : ", ") + b.str();
    std::printf("commissioning requested on %s; follow it with `cobridge status`\n", buses.c_str());
  }
  if (!ok) {
    std::fprintf(stderr, "cobridge: commission: %s\n", (*doc)["error"].str().c_str());
    return 1;
  }
  return 0;
}

}  // namespace cobridge::cli
