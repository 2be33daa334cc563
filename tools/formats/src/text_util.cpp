#include "text_util.hpp"

#include "file_util.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace edgefuse::io::detail {

bool LineReader::next(std::string_view& line) {
  if (p_ >= end_) return false;
  const char* s = p_;
  while (p_ < end_ && *p_ != '\n') ++p_;
  const char* e = p_;
  if (p_ < end_) ++p_;  // skip '\n'
  if (e > s && e[-1] == '\r') --e;
  line = std::string_view(s, std::size_t(e - s));
  ++line_;
  return true;
}

std::string_view trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r' || s[b] == '\n')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '\n')) --e;
  return s.substr(b, e - b);
}

bool is_blank_or_comment(std::string_view line) {
  const std::string_view t = trim(line);
  return t.empty() || t[0] == '#';
}

void split_ws(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t b = i;
    while (i < n && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
}

namespace {
template <class T>
bool parse_whole(std::string_view tok, T& v) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);  // from_chars rejects '+'
  if (tok.empty()) return false;
  const char* e = tok.data() + tok.size();
  const auto r = std::from_chars(tok.data(), e, v);
  return r.ec == std::errc() && r.ptr == e;
}
}  // namespace

bool parse_double(std::string_view tok, double& v) { return parse_whole(tok, v); }
bool parse_float(std::string_view tok, float& v) {
  // Via double so that out-of-range values become +-inf like strtof, not a failure.
  double d;
  if (!parse_whole(tok, d)) return false;
  v = float(d);
  return true;
}
bool parse_int64(std::string_view tok, int64_t& v) { return parse_whole(tok, v); }
bool parse_uint64(std::string_view tok, uint64_t& v) {
  if (!tok.empty() && tok[0] == '-') return false;
  return parse_whole(tok, v);
}

std::string printable(std::string_view text) {
  std::string s;
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c >= 32 && c < 127) {
      s += ch;
    } else {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      s += b;
    }
  }
  return s;
}

std::string quote(std::string_view tok) {
  const std::size_t n = tok.size() < 40 ? tok.size() : 40;
  return "'" + printable(tok.substr(0, n)) + (tok.size() > n ? "..." : "") + "'";
}

bool read_number_matrix(const std::string& path, int rows, int cols, const char* what, double* out,
                        std::string& err) {
  const int count = rows * cols;
  std::string text;
  if (!read_file(path, text, err)) return false;
  if (text.empty()) {
    err = format("%s: empty file, expected a %dx%d %s", path.c_str(), rows, cols, what);
    return false;
  }
  std::vector<std::string_view> tok;
  int n = 0;
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    if (is_blank_or_comment(line)) continue;
    split_ws(line, tok);
    for (std::string_view t : tok) {
      if (n == count) {
        err = format("%s:%d: more than %d numbers, expected a %dx%d matrix", path.c_str(), lines.line_number(), count,
                     rows, cols);
        return false;
      }
      if (!parse_double(t, out[n]) || !std::isfinite(out[n]) || std::fabs(out[n]) > 1e30) {
        err = format("%s:%d: not a finite number: %s", path.c_str(), lines.line_number(), quote(t).c_str());
        return false;
      }
      ++n;
    }
  }
  if (n != count) {
    err = format("%s: holds %d numbers, expected %d (%dx%d matrix)", path.c_str(), n, count, rows, cols);
    return false;
  }
  return true;
}

}  // namespace edgefuse::io::detail
