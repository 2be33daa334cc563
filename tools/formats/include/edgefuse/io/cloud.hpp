// In-memory point clouds and triangle meshes exchanged with PLY and PCD files.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"

namespace edgefuse::io {

//! Optional attribute vectors are empty when absent, else the same length as `points`.
//! An organised cloud (height > 1) keeps its invalid points as NaN so that index = v * width + u.
struct PointCloud {
  int width = 0;  //!< points per row; an unorganised cloud has width = points.size(), height = 1
  int height = 1;
  std::vector<Vec3f> points;
  std::vector<Vec3f> normals;
  std::vector<Rgba8> colours;  //!< a = 0: never seen in colour (PCD "rgb" fields read as a = 255)
  std::vector<uint32_t> labels;
  //! Per-point evidence (fused clouds: SurfacePoint::support, weight units), or empty. PLY property
  //! "support" (uchar), PCD field "support" (U 4).
  std::vector<uint8_t> support;

  bool organised() const { return height > 1; }
  std::size_t size() const { return points.size(); }
};

struct TriangleMesh {
  std::vector<Vec3f> vertices, normals;  //!< normals empty or one per vertex
  std::vector<Rgba8> colours;            //!< empty or one per vertex
  std::vector<std::array<uint32_t, 3>> triangles;  //!< counter-clockwise seen from outside
};

}  // namespace edgefuse::io
