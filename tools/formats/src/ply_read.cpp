// PLY body reader: ascii and binary_little_endian, any element order, unknown data skipped by type.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <new>

#include "bytes.hpp"
#include "edgefuse/io/ply.hpp"
#include "file_util.hpp"
#include "ply_header.hpp"
#include "text_util.hpp"

namespace edgefuse::io {

using detail::format;
using detail::PlyElement;
using detail::PlyType;

namespace {

const char* type_name(PlyType t) {
  static const char* n[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return n[int(t)];
}

// Values of the body, one at a time, as double (exact for every PLY type up to 32-bit integers).
class Cursor {
 public:
  Cursor(const char* p, const char* end, bool ascii) : p_(p), end_(end), ascii_(ascii) {}
  std::size_t remaining() const { return std::size_t(end_ - p_); }
  bool eof() const { return eof_; }
  const std::string& bad_token() const { return bad_; }

  bool read(PlyType t, double& v) {
    return ascii_ ? read_ascii(t, v) : read_binary(t, v);
  }

 private:
  bool read_binary(PlyType t, double& v) {
    const int n = detail::ply_type_size(t);
    if (remaining() < std::size_t(n)) {
      eof_ = true;
      return false;
    }
    const unsigned char* b = reinterpret_cast<const unsigned char*>(p_);
    const uint64_t u = detail::load_le(b, n);
    p_ += n;
    switch (t) {
      case PlyType::kInt8: v = double(int8_t(uint8_t(u))); break;
      case PlyType::kUint8: v = double(uint8_t(u)); break;
      case PlyType::kInt16: v = double(int16_t(uint16_t(u))); break;
      case PlyType::kUint16: v = double(uint16_t(u)); break;
      case PlyType::kInt32: v = double(int32_t(uint32_t(u))); break;
      case PlyType::kUint32: v = double(uint32_t(u)); break;
      case PlyType::kFloat32: v = double(detail::load_le_f32(b)); break;
      case PlyType::kFloat64: v = detail::load_le_f64(b); break;
    }
    return true;
  }

  bool read_ascii(PlyType t, double& v) {
    while (p_ < end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\r' || *p_ == '\n')) ++p_;
    const char* b = p_;
    while (p_ < end_ && !(*p_ == ' ' || *p_ == '\t' || *p_ == '\r' || *p_ == '\n')) ++p_;
    const std::string_view tok(b, std::size_t(p_ - b));
    if (tok.empty()) {
      eof_ = true;
      return false;
    }
    if (!detail::ply_type_is_integer(t)) {
      if (detail::parse_double(tok, v)) return true;
    } else {
      int64_t i = 0;
      static const int64_t lo[] = {-128, 0, -32768, 0, -2147483648LL, 0};
      static const int64_t hi[] = {127, 255, 32767, 65535, 2147483647LL, 4294967295LL};
      if (detail::parse_int64(tok, i) && i >= lo[int(t)] && i <= hi[int(t)]) {
        v = double(i);
        return true;
      }
    }
    bad_ = detail::quote(tok);
    return false;
  }

  const char* p_;
  const char* end_;
  bool ascii_;
  bool eof_ = false;
  std::string bad_;
};

// The smallest number of bytes one entry of the element can take: bounds counts by the file size.
std::size_t min_entry_bytes(const PlyElement& e, bool ascii) {
  std::size_t n = 0;
  for (const auto& p : e.props) n += ascii ? 2 : std::size_t(detail::ply_type_size(p.is_list ? p.count_type : p.type));
  return n;
}

uint8_t to_u8(double v, PlyType t) {
  if (t == PlyType::kFloat32 || t == PlyType::kFloat64) v *= 255.0;  // float colours are 0..1
  else if (t == PlyType::kUint16) v /= 257.0;
  if (!(v > 0)) return 0;
  if (v >= 255) return 255;
  return uint8_t(std::lround(v));
}

struct Body {
  std::vector<Vec3f> points, normals;
  std::vector<Rgba8> colours;
  std::vector<uint32_t> labels;
  std::vector<uint8_t> support;
  std::vector<std::array<uint32_t, 3>> triangles;
  bool has_vertex = false;
};

class Reader {
 public:
  Reader(const std::string& path, Cursor& c, std::string& err) : path_(path), c_(c), err_(err) {}

  bool value_error(const PlyElement& e, uint64_t entry, const detail::PlyProperty& p) {
    if (c_.eof())
      err_ = format("%s: truncated PLY data: element '%s' ends at entry %llu of %llu", path_.c_str(), e.name.c_str(),
                    (unsigned long long)entry, (unsigned long long)e.count);
    else
      err_ = format("%s: element '%s' entry %llu: bad value %s for property '%s' (%s)", path_.c_str(), e.name.c_str(),
                    (unsigned long long)entry, c_.bad_token().c_str(), p.name.c_str(), type_name(p.type));
    return false;
  }

  // Reads a list's length, bounded by what the rest of the file can hold.
  bool list_count(const PlyElement& e, uint64_t entry, const detail::PlyProperty& p, bool ascii, std::size_t& n) {
    double v = 0;
    if (!c_.read(p.count_type, v)) return value_error(e, entry, p);
    if (v < 0) {
      err_ = format("%s: element '%s' entry %llu: negative list length %g", path_.c_str(), e.name.c_str(),
                    (unsigned long long)entry, v);
      return false;
    }
    n = std::size_t(v);
    const std::size_t item = ascii ? 2 : std::size_t(detail::ply_type_size(p.type));
    if (n > c_.remaining() / item + 1) {
      err_ = format("%s: truncated PLY data: element '%s' entry %llu: list of %zu items exceeds the file",
                    path_.c_str(), e.name.c_str(), (unsigned long long)entry, n);
      return false;
    }
    return true;
  }

  bool element(const PlyElement& e, bool ascii, bool want_faces, Body& out) {
    const std::size_t min_bytes = min_entry_bytes(e, ascii);
    if (e.count > 0 && e.props.empty()) {
      err_ = format("%s: element '%s' has %llu entries but no properties", path_.c_str(), e.name.c_str(),
                    (unsigned long long)e.count);
      return false;
    }
    // ascii: the last value of the file may lack a trailing separator, hence the + 1.
    if (e.count > 0 && e.count > (c_.remaining() + 1) / min_bytes) {
      err_ = format("%s: truncated PLY data: header says %llu '%s' entries but the rest of the file (%zu bytes) "
                    "cannot hold them",
                    path_.c_str(), (unsigned long long)e.count, e.name.c_str(), c_.remaining());
      return false;
    }
    if (e.name == "vertex") return vertices(e, ascii, out);
    if (e.name == "face" && want_faces) return faces(e, ascii, out);
    return skip(e, ascii);
  }

 private:
  bool skip(const PlyElement& e, bool ascii) {
    double v;
    for (uint64_t k = 0; k < e.count; ++k)
      for (const auto& p : e.props) {
        std::size_t n = 1;
        if (p.is_list && !list_count(e, k, p, ascii, n)) return false;
        for (std::size_t i = 0; i < n; ++i)
          if (!c_.read(p.type, v)) return value_error(e, k, p);
      }
    return true;
  }

  bool vertices(const PlyElement& e, bool ascii, Body& out) {
    auto idx = [&](const char* a, const char* b = nullptr) {
      int i = e.find(a);
      if (i < 0 && b) i = e.find(b);
      return (i >= 0 && !e.props[std::size_t(i)].is_list) ? i : -1;
    };
    const int x = idx("x"), y = idx("y"), z = idx("z");
    const int nx = idx("nx"), ny = idx("ny"), nz = idx("nz");
    const int r = idx("red", "diffuse_red"), g = idx("green", "diffuse_green"), b = idx("blue", "diffuse_blue");
    const int a = idx("alpha"), label = idx("label"), sup = idx("support");
    if (x < 0 || y < 0 || z < 0) {
      err_ = path_ + ": element 'vertex' lacks scalar x, y and z properties";
      return false;
    }
    const bool has_n = nx >= 0 && ny >= 0 && nz >= 0, has_c = r >= 0 && g >= 0 && b >= 0, has_l = label >= 0;
    const std::size_t n = std::size_t(e.count);
    out.has_vertex = true;
    out.points.resize(n);
    out.normals.resize(has_n ? n : 0);
    out.colours.resize(has_c ? n : 0);
    out.labels.resize(has_l ? n : 0);
    out.support.resize(sup >= 0 ? n : 0);
    std::vector<double> val(e.props.size());
    for (std::size_t k = 0; k < n; ++k) {
      for (std::size_t i = 0; i < e.props.size(); ++i) {
        const auto& p = e.props[i];
        if (!p.is_list) {
          if (!c_.read(p.type, val[i])) return value_error(e, k, p);
          continue;
        }
        std::size_t len = 0;
        double ignored;
        if (!list_count(e, k, p, ascii, len)) return false;
        for (std::size_t j = 0; j < len; ++j)
          if (!c_.read(p.type, ignored)) return value_error(e, k, p);
      }
      out.points[k] = Vec3f(float(val[std::size_t(x)]), float(val[std::size_t(y)]), float(val[std::size_t(z)]));
      if (has_n) out.normals[k] = Vec3f(float(val[std::size_t(nx)]), float(val[std::size_t(ny)]), float(val[std::size_t(nz)]));
      if (has_c) {
        Rgba8& c = out.colours[k];
        c.r = to_u8(val[std::size_t(r)], e.props[std::size_t(r)].type);
        c.g = to_u8(val[std::size_t(g)], e.props[std::size_t(g)].type);
        c.b = to_u8(val[std::size_t(b)], e.props[std::size_t(b)].type);
        c.a = a >= 0 ? to_u8(val[std::size_t(a)], e.props[std::size_t(a)].type) : 255;
      }
      if (has_l) {
        const double l = val[std::size_t(label)];
        out.labels[k] = (l > 0 && l < 4294967296.0) ? uint32_t(l) : 0;
      }
      if (sup >= 0) {
        const double s = val[std::size_t(sup)];
        out.support[k] = s > 0 ? (s < 255 ? uint8_t(s + 0.5) : uint8_t(255)) : uint8_t(0);
      }
    }
    return true;
  }

  bool faces(const PlyElement& e, bool ascii, Body& out) {
    int list = e.find("vertex_indices");
    if (list < 0) list = e.find("vertex_index");
    if (list < 0 || !e.props[std::size_t(list)].is_list || !detail::ply_type_is_integer(e.props[std::size_t(list)].type)) {
      err_ = path_ + ": element 'face' has no integer list property vertex_indices";
      return false;
    }
    out.triangles.reserve(std::size_t(e.count));
    std::vector<uint32_t> poly;
    double v;
    for (uint64_t k = 0; k < e.count; ++k) {
      for (std::size_t i = 0; i < e.props.size(); ++i) {
        const auto& p = e.props[i];
        std::size_t len = 1;
        if (p.is_list && !list_count(e, k, p, ascii, len)) return false;
        if (int(i) != list) {
          for (std::size_t j = 0; j < len; ++j)
            if (!c_.read(p.type, v)) return value_error(e, k, p);
          continue;
        }
        if (len < 3) {
          err_ = format("%s: face %llu has %zu vertices, needs at least 3", path_.c_str(), (unsigned long long)k, len);
          return false;
        }
        poly.clear();
        for (std::size_t j = 0; j < len; ++j) {
          if (!c_.read(p.type, v)) return value_error(e, k, p);
          if (v < 0) {
            err_ = format("%s: face %llu has a negative vertex index %g", path_.c_str(), (unsigned long long)k, v);
            return false;
          }
          poly.push_back(uint32_t(v));
        }
        for (std::size_t j = 1; j + 1 < len; ++j) out.triangles.push_back({poly[0], poly[j], poly[j + 1]});  // fan
      }
    }
    return true;
  }

  const std::string& path_;
  Cursor& c_;
  std::string& err_;
};

bool read_body(const std::string& path, bool want_faces, Body& out, std::string& err) {
  std::string data;
  if (!detail::read_file(path, data, err)) return false;
  detail::PlyHeader h;
  if (!detail::parse_ply_header(path, data, h, err)) return false;
  Cursor c(data.data() + h.data_offset, data.data() + data.size(), h.ascii);
  Reader r(path, c, err);
  for (const PlyElement& e : h.elements)
    if (!r.element(e, h.ascii, want_faces, out)) return false;
  if (!out.has_vertex) {
    err = path + ": PLY file has no 'vertex' element";
    return false;
  }
  const std::size_t nv = out.points.size();
  for (std::size_t t = 0; t < out.triangles.size(); ++t)
    for (uint32_t i : out.triangles[t])
      if (i >= nv) {
        err = format("%s: a face (triangle %zu) refers to vertex %u but there are only %zu vertices", path.c_str(), t,
                     i, nv);
        return false;
      }
  return true;
}

}  // namespace

bool read_ply(const std::string& path, PointCloud& cloud, std::string& err) {
  return detail::guarded(path, err, [&] {
    Body b;
    if (!read_body(path, false, b, err)) return false;
    PointCloud out;
    out.width = int(std::min<std::size_t>(b.points.size(), 2147483647u));
    out.height = 1;
    out.points.swap(b.points);
    out.normals.swap(b.normals);
    out.colours.swap(b.colours);
    out.labels.swap(b.labels);
    out.support.swap(b.support);
    cloud = std::move(out);
    return true;
  });
}

bool read_ply(const std::string& path, TriangleMesh& mesh, std::string& err) {
  return detail::guarded(path, err, [&] {
    Body b;
    if (!read_body(path, true, b, err)) return false;
    TriangleMesh out;
    out.vertices.swap(b.points);
    out.normals.swap(b.normals);
    out.colours.swap(b.colours);
    out.triangles.swap(b.triangles);
    mesh = std::move(out);
    return true;
  });
}

}  // namespace edgefuse::io
