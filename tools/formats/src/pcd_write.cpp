// PCD writer: x y z [normal_x normal_y normal_z] [rgba] [label], ascii / binary / binary_compressed.
#include <lzf.h>

#include <cstring>
#include <exception>
#include <new>

#include "bytes.hpp"
#include "edgefuse/io/pcd.hpp"
#include "file_util.hpp"

namespace edgefuse::io {

using detail::format;

namespace {

uint32_t pack(const Rgba8& c) {
  return (uint32_t(c.a) << 24) | (uint32_t(c.r) << 16) | (uint32_t(c.g) << 8) | uint32_t(c.b);
}

bool write_impl(const std::string& path, const PointCloud& cloud, PcdEncoding enc, std::string& err) {
  const std::size_t n = cloud.points.size();
  if ((!cloud.normals.empty() && cloud.normals.size() != n) || (!cloud.colours.empty() && cloud.colours.size() != n) ||
      (!cloud.labels.empty() && cloud.labels.size() != n) || (!cloud.support.empty() && cloud.support.size() != n)) {
    err = format("%s: %zu points but %zu normals, %zu colours, %zu labels, %zu support values", path.c_str(), n,
                 cloud.normals.size(), cloud.colours.size(), cloud.labels.size(), cloud.support.size());
    return false;
  }
  std::size_t w = std::size_t(cloud.width), h = std::size_t(cloud.height);
  if (cloud.width <= 0 || cloud.height <= 0) {
    w = n;  // unorganised
    h = 1;
  }
  if (w * h != n) {
    err = format("%s: width x height = %d x %d but the cloud has %zu points", path.c_str(), cloud.width, cloud.height, n);
    return false;
  }
  const bool has_n = !cloud.normals.empty(), has_c = !cloud.colours.empty(), has_l = !cloud.labels.empty();
  const bool has_s = !cloud.support.empty();
  // Per-field: name, SIZE, TYPE (all COUNT 1).
  std::string fields = "x y z", sizes = "4 4 4", types = "F F F", counts = "1 1 1";
  if (has_n) fields += " normal_x normal_y normal_z", sizes += " 4 4 4", types += " F F F", counts += " 1 1 1";
  if (has_c) fields += " rgba", sizes += " 4", types += " U", counts += " 1";
  if (has_l) fields += " label", sizes += " 4", types += " U", counts += " 1";
  if (has_s) fields += " support", sizes += " 4", types += " U", counts += " 1";
  const char* data_name = enc == PcdEncoding::kAscii ? "ascii" : enc == PcdEncoding::kBinary ? "binary" : "binary_compressed";
  std::string s = "# .PCD v0.7 - Point Cloud Data file format (written by edgefuse)\nVERSION 0.7\n";
  s += "FIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\nCOUNT " + counts + "\n";
  s += format("WIDTH %zu\nHEIGHT %zu\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %zu\nDATA %s\n", w, h, n, data_name);

  if (enc == PcdEncoding::kAscii) {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3f& p = cloud.points[i];
      s += format("%.9g %.9g %.9g", p.x(), p.y(), p.z());  // %.9g round-trips floats; NaN -> "nan"
      if (has_n) s += format(" %.9g %.9g %.9g", cloud.normals[i].x(), cloud.normals[i].y(), cloud.normals[i].z());
      if (has_c) s += format(" %u", unsigned(pack(cloud.colours[i])));
      if (has_l) s += format(" %u", unsigned(cloud.labels[i]));
      if (has_s) s += format(" %u", unsigned(cloud.support[i]));
      s += '\n';
    }
    return detail::write_file(path, s.data(), s.size(), err);
  }

  // Values as columns (field-major); the binary encoding interleaves them per point below.
  const std::size_t nf = 3 + (has_n ? 3 : 0) + (has_c ? 1 : 0) + (has_l ? 1 : 0) + (has_s ? 1 : 0);
  std::vector<unsigned char> cols(n * nf * 4);
  auto put = [&](std::size_t field, std::size_t i, uint32_t bits) { detail::store_le(&cols[(field * n + i) * 4], bits, 4); };
  auto fbits = [](float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
  };
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t f = 0;
    for (int k = 0; k < 3; ++k) put(f++, i, fbits(cloud.points[i][k]));
    if (has_n)
      for (int k = 0; k < 3; ++k) put(f++, i, fbits(cloud.normals[i][k]));
    if (has_c) put(f++, i, pack(cloud.colours[i]));
    if (has_l) put(f++, i, cloud.labels[i]);
    if (has_s) put(f++, i, cloud.support[i]);
  }
  if (enc == PcdEncoding::kBinary) {
    const std::size_t o = s.size();
    s.resize(o + cols.size());
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t f = 0; f < nf; ++f) std::memcpy(&s[o + (i * nf + f) * 4], &cols[(f * n + i) * 4], 4);
    return detail::write_file(path, s.data(), s.size(), err);
  }
  if (cols.size() > 0xffffffffu / 2) {
    err = path + ": cloud too large for binary_compressed (32-bit sizes)";
    return false;
  }
  // LZF expands incompressible data by at most 1/32 + a few bytes.
  std::vector<unsigned char> packed(cols.size() + cols.size() / 16 + 64);
  const unsigned csize = cols.empty() ? 0u
                                      : lzf_compress(cols.data(), unsigned(cols.size()), packed.data(), unsigned(packed.size()));
  if (!cols.empty() && csize == 0) {
    err = path + ": LZF compression failed";
    return false;
  }
  unsigned char sizes_le[8];
  detail::store_le(sizes_le, csize, 4);
  detail::store_le(sizes_le + 4, cols.size(), 4);
  s.append(reinterpret_cast<const char*>(sizes_le), 8);
  s.append(reinterpret_cast<const char*>(packed.data()), csize);
  return detail::write_file(path, s.data(), s.size(), err);
}

}  // namespace

bool write_pcd(const std::string& path, const PointCloud& cloud, std::string& err, PcdEncoding enc) {
  return detail::guarded(path, err, [&] {
    return write_impl(path, cloud, enc, err);
  });
}

}  // namespace edgefuse::io
