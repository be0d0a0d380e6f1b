#include "app/hash_password_command.hpp"

#include "base/error.hpp"
#include "web/password_hash.hpp"

#include <termios.h>
#include <unistd.h>

#include <optional>
#include <string>

namespace cobridge::app {
namespace {

// One line of `in` without its newline; nullopt at end of input.
std::optional<std::string> read_line(std::FILE* in) {
  std::string line;
  int c;
  while ((c = std::fgetc(in)) != EOF && c != '\n') line += static_cast<char>(c);
  if (c == EOF && line.empty()) return std::nullopt;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// Echo off on the terminal `fd` while alive, restored after (also when a read fails).
class EchoOff {
 public:
  explicit EchoOff(int fd) : fd_(fd), saved_ok_(::tcgetattr(fd, &saved_) == 0) {
    if (!saved_ok_) return;
    termios quiet = saved_;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    (void)::tcsetattr(fd_, TCSAFLUSH, &quiet);
  }
  ~EchoOff() {
    if (saved_ok_) (void)::tcsetattr(fd_, TCSAFLUSH, &saved_);
  }
  EchoOff(const EchoOff&) = delete;
  EchoOff& operator=(const EchoOff&) = delete;

 private:
  int fd_;
  termios saved_{};
  bool saved_ok_;
};

std::optional<std::string> ask(std::FILE* in, std::FILE* err, const char* prompt) {
  std::fputs(prompt, err);
  std::fflush(err);
  const EchoOff quiet(::fileno(in));
  auto line = read_line(in);
  std::fputc('\n', err);  // the newline the terminal did not echo
  return line;
}

// From a terminal: twice, echo off, both the same. Else: the first line.
std::optional<std::string> read_password(std::FILE* in, std::FILE* err) {
  if (::isatty(::fileno(in)) == 0) return read_line(in);
  auto first = ask(in, err, "Password: ");
  if (!first) return std::nullopt;
  auto again = ask(in, err, "Again: ");
  if (!again || *again != *first) {
    std::fputs("cobridged: the two passwords differ\n", err);
    return std::nullopt;
  }
  return first;
}

}  // namespace

int hash_password_command(std::FILE* in, std::FILE* out, std::FILE* err) {
  const std::optional<std::string> password = read_password(in, err);
  if (!password) return exit_code(Errc::kInvalidArgument);
  if (password->empty()) {
    std::fputs("cobridged: an empty password is not hashed\n", err);
    return exit_code(Errc::kInvalidArgument);
  }
  std::string hash;
  if (const Error e = web::hash_password(*password, hash)) {
    std::fprintf(err, "cobridged: %s\n", e.to_string().c_str());
    return exit_code(Errc::kFailed);
  }
  std::fprintf(out, "%s\n", hash.c_str());
  return 0;
}

}  // namespace cobridge::app
