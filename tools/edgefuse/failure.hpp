// How a host command refuses: the message, the exit code (2: the command line, 1: the data; a
// command may add its own, e.g. calibrate's 3: the data does not determine the mounting) and
// whether the command's usage text follows the message.
#pragma once

#include <cstdio>
#include <cstring>
#include <string>

namespace edgefuse::cli {

struct Failure {
  std::string message;
  int code = 1;
  bool usage = false;
};

//! Records a refusal. \param f the refusal  \param message what was wrong  \param code the exit code
//! \return false, so a step can `return fail(f, ...)`
inline bool fail(Failure& f, const std::string& message, int code = 1) {
  f.message = message;
  f.code = code;
  return false;
}

//! Prints "<program>: <message>" to stderr, then the usage when the refusal asks for it.
//! \param program e.g. "edgefuse fuse"  \param f the refusal  \param usage the command's usage text
//! \return the exit code
inline int report(const char* program, const Failure& f, const char* usage = "") {
  std::fprintf(stderr, "%s: %s\n%s", program, f.message.c_str(), f.usage ? usage : "");
  return f.code;
}

//! `--help` / `-h` anywhere on the command line: prints the usage to stdout.
//! \return true when the command should exit 0 now
inline bool help_asked(int argc, char** argv, const char* usage) {
  for (int i = 0; i < argc; ++i)
    if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h")) {
      std::fputs(usage, stdout);
      return true;
    }
  return false;
}

}  // namespace edgefuse::cli
