// Extraction of the fused surface: a point cloud of zero crossings and a marching-cubes mesh.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

struct SurfacePoint {
  Vec3f position;  //!< world frame, metres
  Vec3f normal;    //!< unit, pointing out of the surface (towards free space)
  Rgba8 colour;    //!< a = 0: never seen in colour
  //! Evidence of the point: the weight of the weaker of its crossing's two voxels (units of
  //! volume.hpp: 8 = one sample at the trust reference noise; sigma_eff ~ sigma_ref sqrt(8 / support)
  //! for samples of at least one unit, see fusion/fusion_rules.hpp for sub-unit ones).
  uint8_t support = 0;
};

//! Every zero crossing of the TSDF along the voxel grid's x, y and z edges (both voxels observed,
//! both inside the truncation band), linearly interpolated: a smooth, evenly spaced cloud.
//! \param volume the space
//! \param out output buffer
//! \param capacity its size
//! \param count number written
//! \param min_weight support rule: a crossing is emitted only when both of its voxels hold at least
//!        this weight (units of volume.hpp: 1/8 of a full-trust sample); 0 or 1: every observed pair.
//!        Multi-sensor fusion uses it to drop zero crossings made by one or two samples of a sensor
//!        whose noise is of the order of the truncation (docs/BENCHMARKS.md, "Multi-sensor fusion").
//! \return kOutputTruncated when more points exist than fit (the first `capacity` are written)
Status extract_points(const TsdfVolume& volume, SurfacePoint* out, std::size_t capacity, std::size_t& count,
                      uint8_t min_weight = 0);

//! How much data supports the surface at p: the largest weight of the 8 voxels around it (weight
//! units: 1/8 sample x trust).
//! \param volume the space  \param p world point (metres)
int support_around(const TsdfVolume& volume, const Vec3f& p);

//! Confidence filter: keeps, in order, the points whose support_around() is at least min_weight.
//! \param volume the space  \param points extracted points (compacted in place)  \param count how many
//! \param min_weight weight units (0: every point)  \return the number kept
std::size_t keep_supported(const TsdfVolume& volume, SurfacePoint* points, std::size_t count, int min_weight);

//! Receives the mesh as it is produced (the host writes it to a file; the board may count it).
class MeshSink {
 public:
  virtual ~MeshSink() = default;
  //! \return the new vertex's index (0, 1, 2, ... in call order)
  virtual uint32_t add_vertex(const Vec3f& position, const Vec3f& normal, const Rgba8& colour) = 0;
  //! Counter-clockwise seen from outside (normals point out).
  virtual void add_triangle(uint32_t a, uint32_t b, uint32_t c) = 0;
};

//! Scratch for marching cubes: two z-slices of vertex ids, 3 edges per voxel.
struct MeshScratch {
  uint32_t* edge_ids = nullptr;  //!< 2 * 3 * capacity_dim^2 entries
  std::size_t capacity = 0;      //!< entries available
  static constexpr std::size_t entries_for(int dim) { return 2u * 3u * std::size_t(dim) * std::size_t(dim); }
};

//! Marching cubes over the observed cells (all 8 corners observed); vertices are shared between
//! neighbouring cells, normals from the TSDF gradient, colour interpolated.
//! \param volume the space  \param scratch two z-slices of vertex ids  \param sink receives the mesh
//! \param min_weight support rule of extract_points: a cell is polygonised only when both voxels of
//!        each of its crossing edges hold at least this weight; 0 or 1: every observed cell.
Status extract_mesh(const TsdfVolume& volume, MeshScratch scratch, MeshSink& sink, uint8_t min_weight = 0);

}  // namespace edgefuse
