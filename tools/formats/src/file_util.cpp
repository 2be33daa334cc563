#include "file_util.hpp"

#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>

namespace edgefuse::io::detail {

namespace fs = std::filesystem;

bool read_file(const std::string& path, std::string& data, std::string& err) {
  data.clear();
  std::error_code ec;
  // fopen() succeeds on a directory under Linux; say so instead of a confusing read error.
  if (fs::is_directory(path, ec)) {
    err = path + ": is a directory, expected a file";
    return false;
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    err = path + ": cannot open (" + std::strerror(errno) + ")";
    return false;
  }
  // Grow by reading rather than trusting a size query: pipes and files that change size still work.
  char buf[1 << 16];
  bool ok = true;
  for (;;) {
    const std::size_t n = std::fread(buf, 1, sizeof buf, f);
    try {
      data.append(buf, n);
    } catch (const std::exception&) {  // bad_alloc / length_error: larger than memory
      err = path + ": file too large to read into memory";
      ok = false;
      break;
    }
    if (n < sizeof buf) {
      if (std::ferror(f)) {
        err = path + ": read error (" + std::strerror(errno) + ")";
        ok = false;
      }
      break;
    }
  }
  std::fclose(f);
  return ok;
}

bool write_file(const std::string& path, const void* bytes, std::size_t size, std::string& err) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    err = path + ": cannot create (" + std::strerror(errno) + ")";
    return false;
  }
  const bool wrote = size == 0 || std::fwrite(bytes, 1, size, f) == size;
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!wrote || !closed) {
    err = path + ": write failed (" + std::strerror(wrote ? errno : write_errno) + ")";
    return false;
  }
  return true;
}

std::string join_path(const std::string& dir, const std::string& rel) {
  if (rel.empty()) return dir;
  if (rel[0] == '/' || dir.empty()) return rel;
  if (dir.back() == '/') return dir + rel;
  return dir + "/" + rel;
}

std::string parent_dir(const std::string& path) {
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  const std::size_t slash = p.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return p.substr(0, slash);
}

bool is_regular_file(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

bool is_directory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

std::string format(const char* fmt, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, fmt);
  const int n = std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  if (n < 0) return std::string();
  if (std::size_t(n) < sizeof buf) return std::string(buf, std::size_t(n));
  std::string s(std::size_t(n) + 1, '\0');
  va_start(ap, fmt);
  std::vsnprintf(&s[0], s.size(), fmt, ap);
  va_end(ap);
  s.resize(std::size_t(n));
  return s;
}

}  // namespace edgefuse::io::detail
