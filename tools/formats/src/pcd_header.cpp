#include "pcd_header.hpp"

#include "file_util.hpp"
#include "text_util.hpp"

namespace edgefuse::io::detail {

int PcdHeader::find(const char* name) const {
  for (std::size_t i = 0; i < fields.size(); ++i)
    if (fields[i].name == name) return int(i);
  return -1;
}

namespace {

// The header read so far, one keyword line at a time; every refusal names the file and the line.
struct HeaderParser {
  const std::string& path;
  std::string_view data;
  std::string& err;
  LineReader lines;
  PcdHeader h;
  bool have_fields = false, have_size = false, have_type = false, have_count = false, have_width = false,
       have_points = false;
  std::vector<std::string_view> tok;

  HeaderParser(const std::string& p, std::string_view d, std::string& e) : path(p), data(d), err(e), lines(d) {}

  bool bad(const std::string& what) {
    err = format("%s:%d: %s", path.c_str(), lines.line_number(), what.c_str());
    return false;
  }
  bool per_field(const char* key) {
    if (!have_fields) return bad(std::string(key) + " before FIELDS");
    if (tok.size() - 1 != h.fields.size())
      return bad(format("%s has %zu entries but FIELDS has %zu", key, tok.size() - 1, h.fields.size()));
    return true;
  }
  bool fields() {
    if (tok.size() < 2) return bad("FIELDS lists no fields");
    h.fields.clear();
    for (std::size_t i = 1; i < tok.size(); ++i) {
      PcdField f;
      f.name = std::string(tok[i]);
      h.fields.push_back(f);
    }
    have_fields = true;
    return true;
  }
  bool sizes() {
    if (!per_field("SIZE")) return false;
    for (std::size_t i = 1; i < tok.size(); ++i) {
      uint64_t s = 0;
      if (!parse_uint64(tok[i], s) || (s != 1 && s != 2 && s != 4 && s != 8))
        return bad("SIZE of field '" + h.fields[i - 1].name + "' must be 1, 2, 4 or 8, got " + quote(tok[i]));
      h.fields[i - 1].size = int(s);
    }
    have_size = true;
    return true;
  }
  bool types() {
    if (!per_field("TYPE")) return false;
    for (std::size_t i = 1; i < tok.size(); ++i) {
      if (tok[i] != "F" && tok[i] != "I" && tok[i] != "U")
        return bad("TYPE of field '" + h.fields[i - 1].name + "' must be F, I or U, got " + quote(tok[i]));
      h.fields[i - 1].type = tok[i][0];
    }
    have_type = true;
    return true;
  }
  bool counts() {
    if (!per_field("COUNT")) return false;
    for (std::size_t i = 1; i < tok.size(); ++i) {
      uint64_t c = 0;
      if (!parse_uint64(tok[i], c) || c < 1 || c > (1u << 20))
        return bad("COUNT of field '" + h.fields[i - 1].name + "' must be in 1..1048576, got " + quote(tok[i]));
      h.fields[i - 1].count = uint32_t(c);
    }
    have_count = true;
    return true;
  }
  // WIDTH, HEIGHT or POINTS.
  bool dimension(std::string_view key) {
    uint64_t v = 0;
    // 2^31 per dimension keeps width * height far from overflow; the file size bounds it further.
    if (tok.size() != 2 || !parse_uint64(tok[1], v) || v > 2147483647u)
      return bad(std::string(key) + " must be one integer in 0..2147483647" +
                 (tok.size() > 1 ? ", got " + quote(tok[1]) : std::string()));
    if (key == "WIDTH") {
      h.width = v;
      have_width = true;
    } else if (key == "HEIGHT") {
      h.height = v;
    } else {
      h.points = v;
      have_points = true;
    }
    return true;
  }
  bool viewpoint() {
    if (tok.size() != 8) return bad("VIEWPOINT must have 7 numbers (tx ty tz qw qx qy qz)");
    for (std::size_t i = 1; i < 8; ++i) {
      double d;
      if (!parse_double(tok[i], d)) return bad("VIEWPOINT value " + quote(tok[i]) + " is not a number");
    }
    return true;
  }
  // The DATA line ends the header: the encoding, then the fields' layout and the point count checked.
  bool data_line() {
    if (tok.size() != 2) return bad("expected 'DATA ascii|binary|binary_compressed'");
    if (tok[1] == "ascii") h.data = PcdData::kAscii;
    else if (tok[1] == "binary") h.data = PcdData::kBinary;
    else if (tok[1] == "binary_compressed") h.data = PcdData::kBinaryCompressed;
    else return bad("unknown DATA encoding " + quote(tok[1]) + " (ascii, binary, binary_compressed)");
    if (!have_fields || !have_size || !have_type || !have_width)
      return bad("header lacks FIELDS, SIZE, TYPE or WIDTH before DATA");
    (void)have_count;  // COUNT is optional: 1 per field
    h.point_size = 0;
    for (PcdField& f : h.fields) {
      if (f.type == 'F' && f.size != 4 && f.size != 8)
        return bad(format("field '%s' has TYPE F with SIZE %d (only 4 or 8)", f.name.c_str(), f.size));
      f.offset = h.point_size;
      h.point_size += f.bytes();
    }
    if (h.point_size > (1u << 24)) return bad(format("a point of %zu bytes is implausible", h.point_size));
    const uint64_t wh = h.width * h.height;
    if (have_points && h.points != wh)
      return bad(format("POINTS %llu disagrees with WIDTH x HEIGHT = %llu x %llu = %llu",
                        (unsigned long long)h.points, (unsigned long long)h.width, (unsigned long long)h.height,
                        (unsigned long long)wh));
    h.points = wh;
    h.data_offset = std::size_t(lines.position() - data.data());
    return true;
  }
};

}  // namespace

bool parse_pcd_header(const std::string& path, std::string_view data, PcdHeader& header, std::string& err) {
  if (data.empty()) {
    err = path + ": empty file, expected a PCD file";
    return false;
  }
  HeaderParser p(path, data, err);
  std::string_view line;
  while (p.lines.next(line)) {
    if (is_blank_or_comment(line)) continue;
    split_ws(line, p.tok);
    const std::string_view key = p.tok[0];
    bool ok = true;
    if (key == "VERSION") continue;  // 0.7 and the older .5/.6 share this layout
    if (key == "FIELDS" || key == "COLUMNS") ok = p.fields();
    else if (key == "SIZE") ok = p.sizes();
    else if (key == "TYPE") ok = p.types();
    else if (key == "COUNT") ok = p.counts();
    else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") ok = p.dimension(key);
    else if (key == "VIEWPOINT") ok = p.viewpoint();
    else if (key == "DATA") {
      if (!p.data_line()) return false;
      header = std::move(p.h);
      return true;
    } else {
      return p.bad("not a PCD header line: " + quote(trim(line)));
    }
    if (!ok) return false;
  }
  err = path + ": PCD header has no DATA line (not a PCD file, or truncated)";
  return false;
}

}  // namespace edgefuse::io::detail
