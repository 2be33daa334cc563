// PCD body reader. Every encoding is turned into fixed-size little-endian field values, located
// by a (point, field, element) -> byte address rule: row-wise for binary and parsed ascii,
// column-wise for binary_compressed.
#include <lzf.h>

#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <new>

#include "bytes.hpp"
#include "edgefuse/io/pcd.hpp"
#include "file_util.hpp"
#include "pcd_header.hpp"
#include "text_util.hpp"

namespace edgefuse::io {

using detail::format;
using detail::PcdData;
using detail::PcdField;
using detail::PcdHeader;

namespace {

// Where field values live: point i, field f, element c at base + i * stride(f) + start(f) + c * size.
struct Layout {
  const unsigned char* base = nullptr;
  std::vector<std::size_t> start, stride;
  const unsigned char* at(std::size_t i, std::size_t f, std::size_t c, int size) const {
    return base + i * stride[f] + start[f] + c * std::size_t(size);
  }
};

double value(const unsigned char* p, const PcdField& f) {
  const uint64_t u = detail::load_le(p, f.size);
  if (f.type == 'F') return f.size == 4 ? double(detail::load_le_f32(p)) : detail::load_le_f64(p);
  if (f.type == 'U') return double(u);
  switch (f.size) {  // sign-extend
    case 1: return double(int8_t(uint8_t(u)));
    case 2: return double(int16_t(uint16_t(u)));
    case 4: return double(int32_t(uint32_t(u)));
    default: return double(int64_t(u));
  }
}

// ascii token -> the field's binary representation.
bool encode_token(std::string_view tok, const PcdField& f, unsigned char* out) {
  const bool packed_colour = f.size == 4 && (f.name == "rgb" || f.name == "rgba");
  if (f.type == 'F') {
    // PCL writes packed colour as the integer of its bits even in F fields; a float text is the
    // older form. Digits only means the bit pattern.
    if (packed_colour && tok.find_first_not_of("0123456789") == std::string_view::npos) {
      uint64_t bits = 0;
      if (!detail::parse_uint64(tok, bits) || bits > 0xffffffffu) return false;
      detail::store_le(out, bits, 4);
      return true;
    }
    double d = 0;
    if (!detail::parse_double(tok, d)) return false;
    if (f.size == 8) {
      uint64_t bits;
      std::memcpy(&bits, &d, 8);
      detail::store_le(out, bits, 8);
    } else {
      detail::store_le_f32(out, float(d));
    }
    return true;
  }
  if (f.type == 'U') {
    uint64_t v = 0;
    if (!detail::parse_uint64(tok, v) || (f.size < 8 && v >> (8 * f.size))) return false;
    detail::store_le(out, v, f.size);
    return true;
  }
  int64_t v = 0;
  if (!detail::parse_int64(tok, v)) return false;
  if (f.size < 8) {
    const int64_t lim = int64_t(1) << (8 * f.size - 1);
    if (v < -lim || v >= lim) return false;
  }
  detail::store_le(out, uint64_t(v), f.size);
  return true;
}

bool parse_ascii(const std::string& path, const std::string& data, const PcdHeader& h, std::vector<unsigned char>& rows,
                 std::string& err) {
  std::size_t tokens_per_point = 0;
  for (const PcdField& f : h.fields) tokens_per_point += f.count;
  // Each value takes at least two bytes ("0 "), so the file bounds the point count.
  const std::size_t remaining = data.size() - h.data_offset;
  if (h.points > (remaining + 1) / (2 * tokens_per_point)) {
    err = format("%s: header says %llu points but the data (%zu bytes) cannot hold them", path.c_str(),
                 (unsigned long long)h.points, remaining);
    return false;
  }
  if (h.points > std::numeric_limits<std::size_t>::max() / h.point_size) {  // 32-bit size_t
    err = format("%s: %llu points are too many for this machine", path.c_str(), (unsigned long long)h.points);
    return false;
  }
  rows.assign(std::size_t(h.points) * h.point_size, 0);
  detail::LineReader lines(data.data() + h.data_offset, data.data() + data.size());
  std::vector<std::string_view> tok;
  std::string_view line;
  std::size_t n = 0;
  // Header lines come first: report body line numbers as file line numbers.
  int header_lines = 0;
  for (std::size_t i = 0; i < h.data_offset; ++i) header_lines += data[i] == '\n';
  while (lines.next(line)) {
    const int ln = header_lines + lines.line_number();
    if (detail::is_blank_or_comment(line)) continue;
    detail::split_ws(line, tok);
    if (n == h.points) {
      err = format("%s:%d: header says %llu points but the data holds more", path.c_str(), ln,
                   (unsigned long long)h.points);
      return false;
    }
    if (tok.size() != tokens_per_point) {
      err = format("%s:%d: %zu values, expected %zu", path.c_str(), ln, tok.size(), tokens_per_point);
      return false;
    }
    unsigned char* row = rows.data() + n * h.point_size;
    std::size_t t = 0;
    for (const PcdField& f : h.fields)
      for (uint32_t c = 0; c < f.count; ++c, ++t)
        if (!encode_token(tok[t], f, row + f.offset + std::size_t(c) * std::size_t(f.size))) {
          err = format("%s:%d: bad value %s for field '%s' (%c%d)", path.c_str(), ln, detail::quote(tok[t]).c_str(),
                       f.name.c_str(), f.type, f.size);
          return false;
        }
    ++n;
  }
  if (n != h.points) {
    err = format("%s: header says %llu points but the data holds %zu", path.c_str(), (unsigned long long)h.points, n);
    return false;
  }
  return true;
}

bool decompress(const std::string& path, const std::string& data, const PcdHeader& h, std::vector<unsigned char>& cols,
                std::string& err) {
  const std::size_t remaining = data.size() - h.data_offset;
  if (remaining < 8) {
    err = path + ": truncated PCD: binary_compressed data lacks its 8-byte size header";
    return false;
  }
  const unsigned char* p = reinterpret_cast<const unsigned char*>(data.data()) + h.data_offset;
  const uint64_t csize = detail::load_le_u32(p), usize = detail::load_le_u32(p + 4);
  // points <= 2^62 and point_size <= 2^24: test before multiplying.
  const uint64_t need = h.points <= 0xffffffffull / h.point_size ? h.points * h.point_size : ~0ull;
  if (usize != need) {
    err = format("%s: LZF header says %llu uncompressed bytes but %llu points x %zu bytes = %llu", path.c_str(),
                 (unsigned long long)usize, (unsigned long long)h.points, h.point_size, (unsigned long long)need);
    return false;
  }
  if (csize > remaining - 8) {
    err = format("%s: truncated PCD: LZF block of %llu bytes but only %zu bytes follow", path.c_str(),
                 (unsigned long long)csize, remaining - 8);
    return false;
  }
  // An LZF back-reference (3 bytes) expands to at most 264 bytes: larger claims are lies.
  if (usize > 100 * csize + 64) {
    err = format("%s: LZF sizes are impossible (%llu bytes cannot expand to %llu)", path.c_str(),
                 (unsigned long long)csize, (unsigned long long)usize);
    return false;
  }
  cols.assign(std::size_t(usize), 0);
  if (usize == 0) return true;
  const unsigned got = lzf_decompress(p + 8, unsigned(csize), cols.data(), unsigned(usize));
  if (got != usize) {
    err = format("%s: corrupt LZF data (decompressed %u of %llu bytes)", path.c_str(), got, (unsigned long long)usize);
    return false;
  }
  return true;
}

// Reads a scalar field (COUNT 1) of numeric type, for x y z / normals / label.
bool scalar_field(const std::string& path, const PcdHeader& h, const char* name, int& index, std::string& err) {
  index = h.find(name);
  if (index >= 0 && h.fields[std::size_t(index)].count != 1) {
    err = format("%s: field '%s' must have COUNT 1, got %u", path.c_str(), name, h.fields[std::size_t(index)].count);
    return false;
  }
  return true;
}

bool extract(const std::string& path, const PcdHeader& h, const Layout& L, PointCloud& out, std::string& err) {
  int x, y, z, nx, ny, nz, label;
  if (!scalar_field(path, h, "x", x, err) || !scalar_field(path, h, "y", y, err) || !scalar_field(path, h, "z", z, err) ||
      !scalar_field(path, h, "normal_x", nx, err) || !scalar_field(path, h, "normal_y", ny, err) ||
      !scalar_field(path, h, "normal_z", nz, err) || !scalar_field(path, h, "label", label, err))
    return false;
  if (x < 0 || y < 0 || z < 0) {
    err = path + ": PCD has no x, y and z fields";
    return false;
  }
  int rgb = h.find("rgba");
  const bool has_alpha = rgb >= 0;
  if (rgb < 0) rgb = h.find("rgb");
  if (rgb >= 0 && (h.fields[std::size_t(rgb)].size != 4 || h.fields[std::size_t(rgb)].count != 1)) {
    err = path + ": field '" + h.fields[std::size_t(rgb)].name + "' must be one 4-byte packed colour";
    return false;
  }
  const bool has_n = nx >= 0 && ny >= 0 && nz >= 0;
  const std::size_t n = std::size_t(h.points);
  out.width = int(h.width);
  out.height = int(h.height);
  out.points.resize(n);
  out.normals.resize(has_n ? n : 0);
  out.colours.resize(rgb >= 0 ? n : 0);
  out.labels.resize(label >= 0 ? n : 0);
  auto get = [&](std::size_t i, int f) {
    const PcdField& fd = h.fields[std::size_t(f)];
    return value(L.at(i, std::size_t(f), 0, fd.size), fd);
  };
  for (std::size_t i = 0; i < n; ++i) {
    out.points[i] = Vec3f(float(get(i, x)), float(get(i, y)), float(get(i, z)));
    if (has_n) out.normals[i] = Vec3f(float(get(i, nx)), float(get(i, ny)), float(get(i, nz)));
    if (rgb >= 0) {
      const uint32_t c = detail::load_le_u32(L.at(i, std::size_t(rgb), 0, 4));  // 0xAARRGGBB
      Rgba8& o = out.colours[i];
      o.r = uint8_t(c >> 16);
      o.g = uint8_t(c >> 8);
      o.b = uint8_t(c);
      o.a = has_alpha ? uint8_t(c >> 24) : 255;  // "rgb" carries no alpha: the point was seen in colour
    }
    if (label >= 0) {
      const double l = get(i, label);
      out.labels[i] = (l > 0 && l < 4294967296.0) ? uint32_t(l) : 0;
    }
  }
  return true;
}

}  // namespace

bool read_pcd(const std::string& path, PointCloud& cloud, std::string& err) {
  return detail::guarded(path, err, [&] {
    std::string data;
    if (!detail::read_file(path, data, err)) return false;
    PcdHeader h;
    if (!detail::parse_pcd_header(path, data, h, err)) return false;
    if (h.width > 0 && h.height > 0 && h.point_size == 0) {
      err = path + ": PCD fields take no bytes";
      return false;
    }
    Layout L;
    L.start.resize(h.fields.size());
    L.stride.resize(h.fields.size());
    std::vector<unsigned char> buf;
    const std::size_t remaining = data.size() - h.data_offset;
    if (h.data == PcdData::kBinaryCompressed) {
      if (!decompress(path, data, h, buf, err)) return false;
      L.base = buf.data();
      std::size_t col = 0;  // column-wise: all of field 0, then all of field 1, ...
      for (std::size_t f = 0; f < h.fields.size(); ++f) {
        L.start[f] = col;
        L.stride[f] = h.fields[f].bytes();
        col += std::size_t(h.points) * h.fields[f].bytes();
      }
    } else {
      if (h.data == PcdData::kBinary) {
        if (h.points > remaining / h.point_size) {
          err = format("%s: header says %llu points but the data holds %zu", path.c_str(),
                       (unsigned long long)h.points, remaining / h.point_size);
          return false;
        }
        L.base = reinterpret_cast<const unsigned char*>(data.data()) + h.data_offset;
      } else {
        if (!parse_ascii(path, data, h, buf, err)) return false;
        L.base = buf.data();
      }
      for (std::size_t f = 0; f < h.fields.size(); ++f) {
        L.start[f] = h.fields[f].offset;
        L.stride[f] = h.point_size;
      }
    }
    PointCloud out;
    if (!extract(path, h, L, out, err)) return false;
    cloud = std::move(out);
    return true;
  });
}

}  // namespace edgefuse::io
