// Helpers for the tools/formats suites: a scratch folder, raw file I/O, cut/garbage variants of a
// valid file, and the check that a failure message names the file. Include the edgefuse headers
// first; this header includes test_support.hpp (CppUTest) last.
#pragma once

#include <stdlib.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace formats_test {

//! A fresh folder under /tmp (mkdtemp), removed with everything in it at scope exit.
class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/edgefuse_formats_XXXXXX";
    const char* d = mkdtemp(tmpl);
    path_ = d ? d : "/tmp";
  }
  ~TempDir() {
    std::error_code ec;
    if (path_ != "/tmp") std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

inline void write_bytes(const std::string& path, const std::string& bytes) {
  // Unlink first: ext4 flushes a truncated-and-rewritten file on close (auto_da_alloc), ~3 ms each.
  std::remove(path.c_str());
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), std::streamsize(bytes.size()));
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

//! Deterministic bytes (a 32-bit LCG: same on every host).
inline std::string garbage(std::size_t n, uint32_t seed) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) {
    seed = seed * 1664525u + 1013904223u;
    s[i] = char(seed >> 24);
  }
  return s;
}

//! Asserts a failed read whose message names the file.
#define CHECK_FAILS_NAMING(ok, err, path)                                                        \
  do {                                                                                           \
    CHECK_FALSE_TEXT((ok), ("expected a failure for " + std::string(path)).c_str());            \
    CHECK_TEXT((err).find(path) != std::string::npos, ("message lacks the file name: " + (err)).c_str()); \
  } while (0)

//! A reader under test: returns success, sets the message.
using Reader = std::function<bool(const std::string& path, std::string& err)>;

//! The lengths at which a file of `n` bytes is cut: every length for small files, else a spread
//! including the first bytes, the header region and the very end.
inline std::vector<std::size_t> cut_lengths(std::size_t n) {
  std::vector<std::size_t> cuts;
  if (n <= 1500) {
    for (std::size_t k = 0; k < n; ++k) cuts.push_back(k);
    return cuts;
  }
  for (std::size_t k = 0; k < 300; ++k) cuts.push_back(k);
  for (std::size_t k = 1; k < 40; ++k) cuts.push_back(n * k / 40);
  for (std::size_t k = 1; k <= 16; ++k) cuts.push_back(n - k);
  return cuts;
}

//! Cuts `bytes` at many lengths; each cut must fail naming the file (strict) or, for text formats
//! where a cut can leave a valid shorter file, at least not crash and name the file on failure.
inline void check_truncations(const TempDir& dir, const std::string& name, const std::string& bytes,
                              const Reader& read, bool strict) {
  const std::string path = dir.file(name);
  for (std::size_t len : cut_lengths(bytes.size())) {
    write_bytes(path, bytes.substr(0, len));
    std::string err;
    const bool ok = read(path, err);
    if (strict || !ok) {
      const std::string what = "cut at " + std::to_string(len) + " of " + std::to_string(bytes.size()) + ": " + err;
      CHECK_FALSE_TEXT(ok, what.c_str());
      CHECK_TEXT(err.find(path) != std::string::npos, what.c_str());
    }
  }
}

//! Missing file, a folder, an empty file and garbage (alone and after `prefix`, e.g. a valid
//! header start) must all fail naming the path.
inline void check_bad_files(const TempDir& dir, const std::string& name, const Reader& read,
                            const std::string& prefix = std::string()) {
  std::string err;
  const std::string missing = dir.file("missing_" + name);
  CHECK_FAILS_NAMING(read(missing, err), err, missing);
  const std::string folder = dir.file("folder_" + name);
  std::filesystem::create_directory(folder);
  CHECK_FAILS_NAMING(read(folder, err), err, folder);
  const std::string path = dir.file(name);
  write_bytes(path, "");
  CHECK_FAILS_NAMING(read(path, err), err, path);
  for (uint32_t seed = 1; seed <= 8; ++seed) {
    write_bytes(path, garbage(100 + 997 * seed, seed));
    CHECK_FAILS_NAMING(read(path, err), err, path);
    if (!prefix.empty()) {
      write_bytes(path, prefix + garbage(50 + 331 * seed, seed + 100));
      CHECK_FAILS_NAMING(read(path, err), err, path);
    }
  }
}

//! Writes `text` to `name` and expects `read` to fail naming the file and saying `needle`.
inline void check_bad_text(const TempDir& dir, const std::string& name, const std::string& text, const Reader& read,
                           const std::string& needle) {
  const std::string path = dir.file(name);
  write_bytes(path, text);
  std::string err;
  const bool ok = read(path, err);
  CHECK_FAILS_NAMING(ok, err, path);
  CHECK_TEXT(err.find(needle) != std::string::npos, ("expected '" + needle + "' in: " + err).c_str());
}

}  // namespace formats_test
