// `cobridged --hash-password`: reads a password and prints its yescrypt hash,
// the form web.auth_file's "user:hash" lines take (docs/web.md), so an
// operator needs no other tool (mkpasswd, openssl) to make one.
//
// The password is never an argument (it would be in the shell's history and
// in /proc/<pid>/cmdline): from a terminal it is asked twice with echo off,
// otherwise it is the first line of standard input (scripts:
// `printf '%s\n' "$pw" | cobridged --hash-password`).
//
// Thread: the main thread; nothing else runs.
#pragma once

#include <cstdio>

namespace cobridge::app {

// Prints the hash and a newline on `out`, prompts and problems on `err`;
// returns the exit status: 0, 2 (no password, or the two differ), 1 (libcrypt failed).
[[nodiscard]] int hash_password_command(std::FILE* in, std::FILE* out, std::FILE* err);

}  // namespace cobridge::app
