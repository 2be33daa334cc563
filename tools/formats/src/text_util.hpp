// Locale-independent parsing of whitespace-separated text files (TUM lists, poses, PCD/PLY ascii).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace edgefuse::io::detail {

//! Iterates over the lines of a buffer ("\n" or "\r\n"), counting them from 1.
class LineReader {
 public:
  LineReader(const char* begin, const char* end) : p_(begin), end_(end) {}
  explicit LineReader(std::string_view s) : p_(s.data()), end_(s.data() + s.size()) {}
  //! Next line without its terminator; false at the end of the buffer.
  bool next(std::string_view& line);
  int line_number() const { return line_; }
  //! Bytes not yet consumed.
  std::size_t remaining() const { return std::size_t(end_ - p_); }
  const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
  int line_ = 0;
};

std::string_view trim(std::string_view s);
//! Blank, or a comment starting with '#'.
bool is_blank_or_comment(std::string_view line);
//! Splits on spaces/tabs into `out` (cleared first).
void split_ws(std::string_view line, std::vector<std::string_view>& out);

//! Whole-token number parsers (no locale; "nan"/"inf" accepted for floating point; a leading '+'
//! is allowed). False when the token is not entirely a number of that type.
bool parse_double(std::string_view tok, double& v);
bool parse_float(std::string_view tok, float& v);
bool parse_int64(std::string_view tok, int64_t& v);
bool parse_uint64(std::string_view tok, uint64_t& v);

//! Short printable quote of a token for messages (clipped, control bytes escaped).
std::string quote(std::string_view tok);
//! `text` with bytes outside printable ASCII written as \xNN (not quoted, not shortened): file
//! names taken from a file, for messages.
std::string printable(std::string_view text);

//! Reads a file holding exactly rows x cols whitespace-separated finite numbers (|v| <= 1e30,
//! comments and blank lines allowed) into `out`, row-major. `what` names the matrix in messages.
bool read_number_matrix(const std::string& path, int rows, int cols, const char* what, double* out,
                        std::string& err);

}  // namespace edgefuse::io::detail
