#include "edgefuse/io/mesh_collector.hpp"

#include "edgefuse/io/ply.hpp"

namespace edgefuse::io {

uint32_t PlyMeshCollector::add_vertex(const Vec3f& position, const Vec3f& normal, const Rgba8& colour) {
  mesh_.vertices.push_back(position);
  mesh_.normals.push_back(normal);
  mesh_.colours.push_back(colour);
  return uint32_t(mesh_.vertices.size() - 1);
}

void PlyMeshCollector::add_triangle(uint32_t a, uint32_t b, uint32_t c) { mesh_.triangles.push_back({a, b, c}); }

bool PlyMeshCollector::write(const std::string& path, std::string& err) const {
  for (const Rgba8& c : mesh_.colours)
    if (c.a != 0) return write_ply(path, mesh_, err);
  // No vertex was seen in colour (a geometry-only run): all-black colours would only mislead viewers.
  TriangleMesh plain;
  plain.vertices = mesh_.vertices;
  plain.normals = mesh_.normals;
  plain.triangles = mesh_.triangles;
  return write_ply(path, plain, err);
}

}  // namespace edgefuse::io
