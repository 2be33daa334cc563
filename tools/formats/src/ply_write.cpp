// PLY writers: points and meshes, binary_little_endian (default) or ascii.
#include <exception>
#include <new>

#include "bytes.hpp"
#include "edgefuse/io/ply.hpp"
#include "file_util.hpp"

namespace edgefuse::io {

using detail::format;

namespace {

struct VertexData {
  const std::vector<Vec3f>& pos;
  const std::vector<Vec3f>& nrm;
  const std::vector<Rgba8>& col;
  const std::vector<uint32_t>* lab;  // null: none
  const std::vector<uint8_t>* sup;   // null: none
};

bool check_attributes(const std::string& path, const VertexData& v, std::string& err) {
  const std::size_t n = v.pos.size();
  if ((!v.nrm.empty() && v.nrm.size() != n) || (!v.col.empty() && v.col.size() != n) ||
      (v.lab && !v.lab->empty() && v.lab->size() != n) || (v.sup && !v.sup->empty() && v.sup->size() != n)) {
    err = format("%s: %zu points but %zu normals, %zu colours, %zu labels, %zu support values", path.c_str(), n,
                 v.nrm.size(), v.col.size(), v.lab ? v.lab->size() : std::size_t(0),
                 v.sup ? v.sup->size() : std::size_t(0));
    return false;
  }
  return true;
}

std::string header(const VertexData& v, std::size_t faces, bool with_faces, PlyEncoding enc) {
  std::string h = "ply\n";
  h += enc == PlyEncoding::kAscii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
  h += "comment written by edgefuse\n";
  h += format("element vertex %zu\n", v.pos.size());
  h += "property float x\nproperty float y\nproperty float z\n";
  if (!v.nrm.empty()) h += "property float nx\nproperty float ny\nproperty float nz\n";
  if (!v.col.empty()) h += "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n";
  if (v.lab && !v.lab->empty()) h += "property uint label\n";
  if (v.sup && !v.sup->empty()) h += "property uchar support\n";
  if (with_faces) h += format("element face %zu\nproperty list uchar uint vertex_indices\n", faces);
  h += "end_header\n";
  return h;
}

void append_vertices(std::string& s, const VertexData& v, PlyEncoding enc) {
  const bool has_l = v.lab && !v.lab->empty();
  const bool has_s = v.sup && !v.sup->empty();
  if (enc == PlyEncoding::kAscii) {
    for (std::size_t i = 0; i < v.pos.size(); ++i) {
      // %.9g round-trips every float exactly.
      s += format("%.9g %.9g %.9g", v.pos[i].x(), v.pos[i].y(), v.pos[i].z());
      if (!v.nrm.empty()) s += format(" %.9g %.9g %.9g", v.nrm[i].x(), v.nrm[i].y(), v.nrm[i].z());
      if (!v.col.empty()) s += format(" %u %u %u %u", v.col[i].r, v.col[i].g, v.col[i].b, v.col[i].a);
      if (has_l) s += format(" %u", unsigned((*v.lab)[i]));
      if (has_s) s += format(" %u", unsigned((*v.sup)[i]));
      s += '\n';
    }
    return;
  }
  const std::size_t rec = 12 + (v.nrm.empty() ? 0 : 12) + (v.col.empty() ? 0 : 4) + (has_l ? 4 : 0) + (has_s ? 1 : 0);
  std::size_t o = s.size();
  s.resize(o + rec * v.pos.size());
  unsigned char* p = reinterpret_cast<unsigned char*>(&s[0]);
  for (std::size_t i = 0; i < v.pos.size(); ++i) {
    for (int k = 0; k < 3; ++k, o += 4) detail::store_le_f32(p + o, v.pos[i][k]);
    if (!v.nrm.empty())
      for (int k = 0; k < 3; ++k, o += 4) detail::store_le_f32(p + o, v.nrm[i][k]);
    if (!v.col.empty()) {
      p[o++] = v.col[i].r;
      p[o++] = v.col[i].g;
      p[o++] = v.col[i].b;
      p[o++] = v.col[i].a;
    }
    if (has_l) {
      detail::store_le(p + o, (*v.lab)[i], 4);
      o += 4;
    }
    if (has_s) p[o++] = (*v.sup)[i];
  }
}

}  // namespace

bool write_ply(const std::string& path, const PointCloud& cloud, std::string& err, PlyEncoding enc) {
  return detail::guarded(path, err, [&] {
    const VertexData v{cloud.points, cloud.normals, cloud.colours, &cloud.labels, &cloud.support};
    if (!check_attributes(path, v, err)) return false;
    std::string s = header(v, 0, false, enc);
    append_vertices(s, v, enc);
    return detail::write_file(path, s.data(), s.size(), err);
  });
}

bool write_ply(const std::string& path, const TriangleMesh& mesh, std::string& err, PlyEncoding enc) {
  return detail::guarded(path, err, [&] {
    const VertexData v{mesh.vertices, mesh.normals, mesh.colours, nullptr, nullptr};
    if (!check_attributes(path, v, err)) return false;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      for (uint32_t i : mesh.triangles[t])
        if (i >= mesh.vertices.size()) {
          err = format("%s: triangle %zu refers to vertex %u of %zu", path.c_str(), t, i, mesh.vertices.size());
          return false;
        }
    std::string s = header(v, mesh.triangles.size(), true, enc);
    append_vertices(s, v, enc);
    if (enc == PlyEncoding::kAscii) {
      for (const auto& t : mesh.triangles) s += format("3 %u %u %u\n", t[0], t[1], t[2]);
    } else {
      std::size_t o = s.size();
      s.resize(o + 13 * mesh.triangles.size());
      unsigned char* p = reinterpret_cast<unsigned char*>(&s[0]);
      for (const auto& t : mesh.triangles) {
        p[o++] = 3;
        for (int k = 0; k < 3; ++k, o += 4) detail::store_le(p + o, t[std::size_t(k)], 4);
      }
    }
    return detail::write_file(path, s.data(), s.size(), err);
  });
}

}  // namespace edgefuse::io
