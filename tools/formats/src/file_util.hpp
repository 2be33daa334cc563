// Whole-file I/O and path helpers shared by the readers. Every message starts with the path.
#pragma once

#include <cstddef>
#include <exception>
#include <new>
#include <string>

namespace edgefuse::io::detail {

//! Reads the whole file. Fails (message "<path>: cannot open (...)") for missing files and
//! directories; an empty file succeeds with empty `data` (each reader words that error itself).
bool read_file(const std::string& path, std::string& data, std::string& err);

//! Writes `size` bytes, replacing the file.
bool write_file(const std::string& path, const void* bytes, std::size_t size, std::string& err);

//! `rel` relative to directory `dir` (returned unchanged when absolute).
std::string join_path(const std::string& dir, const std::string& rel);

//! The folder part of a path ("." when there is none).
std::string parent_dir(const std::string& path);

bool is_regular_file(const std::string& path);
bool is_directory(const std::string& path);

//! printf into a std::string (messages only).
std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

//! Runs a reader/writer body, turning any exception (bad_alloc on a huge but plausible size,
//! a library error) into a message naming the file: exceptions never leave the API.
template <class F>
bool guarded(const std::string& path, std::string& err, F&& f) {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    err = path + ": out of memory";
  } catch (const std::exception& e) {
    err = path + ": " + e.what();
  }
  return false;
}

}  // namespace edgefuse::io::detail
