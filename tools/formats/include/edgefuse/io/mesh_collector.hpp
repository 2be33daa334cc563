// Collects the mesh the core streams through MeshSink (extract_mesh) for write_ply.
#pragma once

#include "edgefuse/io/cloud.hpp"
#include "edgefuse/tsdf/extract.hpp"

namespace edgefuse::io {

class PlyMeshCollector : public MeshSink {
 public:
  uint32_t add_vertex(const Vec3f& position, const Vec3f& normal, const Rgba8& colour) override;
  void add_triangle(uint32_t a, uint32_t b, uint32_t c) override;

  const TriangleMesh& mesh() const { return mesh_; }
  TriangleMesh& mesh() { return mesh_; }
  void clear() { mesh_ = TriangleMesh(); }
  //! write_ply(path, mesh()); colours are dropped when no vertex was ever seen in colour.
  bool write(const std::string& path, std::string& err) const;

 private:
  TriangleMesh mesh_;
};

}  // namespace edgefuse::io
