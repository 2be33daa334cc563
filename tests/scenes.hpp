// Analytic scenes drawn by the tests: planes, spheres and boxes rendered exactly into depth
// (and colour) images, and static storage for small volumes. Setup code: may allocate.
#pragma once

#include <cstdint>
#include <vector>

#include "edgefuse/core/image.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/sensor/pinhole.hpp"
#include "edgefuse/tsdf/frame_scratch.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse_test {

using edgefuse::Pose;
using edgefuse::Vec3f;

struct Primitive {
  enum Kind { kPlane, kSphere, kBox } kind;
  Vec3f a;                 //!< plane: unit normal; sphere: centre; box: centre
  Vec3f b;                 //!< plane: (offset d, -, -) with n.x + d = 0; sphere: (radius, -, -); box: half sizes
  Pose T_world_box;        //!< box orientation (translation unused: a is the centre)
  edgefuse::Rgb8 colour;
};

struct Scene {
  std::vector<Primitive> items;
  void add_plane(const Vec3f& n, float d, edgefuse::Rgb8 c = {200, 200, 200});
  void add_sphere(const Vec3f& centre, float radius, edgefuse::Rgb8 c = {200, 50, 50});
  void add_box(const Vec3f& centre, const Vec3f& half, const Pose& R, edgefuse::Rgb8 c = {50, 200, 50});
  //! Nearest hit along origin + t dir (t > 0): distance t, the unit normal and the item; false if none.
  bool intersect(const Vec3f& origin, const Vec3f& dir, float& t, Vec3f& normal, int& item) const;
};

//! Exact z-depth image (raw = round(z * depth_scale), 0 = no hit or outside the range limits) and,
//! optionally, colour. Also returns the incidence angle cosine per pixel (for masking grazing views).
void render(const Scene& scene, const edgefuse::PinholeIntrinsics& intr, const Pose& T_world_cam,
            std::vector<uint16_t>& depth, std::vector<edgefuse::Rgb8>* colour = nullptr,
            std::vector<float>* cos_incidence = nullptr, std::vector<int>* item = nullptr);

//! bin_rig_a's ToF camera (160x120, rig.toml's intrinsics, 0.1-1.5 m): the filter and fusion tests
//! render its frames.
edgefuse::PinholeIntrinsics bin_rig_a_tof_camera();

//! Camera at eye looking at target, image y roughly along `down`.
Pose look_at(const Vec3f& eye, const Vec3f& target, const Vec3f& down = Vec3f(0, 1, 0));

//! Static buffers for a test volume of Dim^3 voxels (with colour).
template <int Dim>
struct VolumeStorage {
  static constexpr std::size_t kBricks = std::size_t(Dim) * Dim * Dim / edgefuse::kBrickVoxels;
  static constexpr std::size_t kVoxels = (kBricks + 1) * edgefuse::kBrickVoxels;  // a full pool
  int16_t tsdf[kVoxels];
  uint8_t weight[kVoxels];
  edgefuse::Rgb8 colour[kVoxels];
  uint8_t colour_weight[kVoxels];
  uint32_t slots[kBricks];
  uint8_t flags[kBricks];
  uint32_t list[kBricks];
  uint64_t block_mask[kBricks];
  edgefuse::VoxelStorage view(bool with_colour = true) {
    edgefuse::VoxelStorage s;
    s.tsdf = tsdf;
    s.weight = weight;
    s.colour = with_colour ? colour : nullptr;
    s.colour_weight = with_colour ? colour_weight : nullptr;
    s.brick_slot = slots;
    s.brick_flags = flags;
    s.brick_list = list;
    s.block_mask = block_mask;
    s.capacity_dim = Dim;
    s.pool_bricks = uint32_t(kBricks + 1);
    return s;
  }
};

//! Calls f(ia, ib) with the indices of the same voxel in volumes a and b (same dim), brick by brick:
//! each volume's pool holds its bricks in the order they were first written.
template <class F>
void for_each_voxel_pair(const edgefuse::TsdfVolume& a, const edgefuse::TsdfVolume& b, F f) {
  for (std::size_t brick = 0; brick < a.brick_count(); ++brick) {
    const std::size_t ba = a.brick_base(brick), bb = b.brick_base(brick);
    for (int i = 0; i < edgefuse::kBrickVoxels; ++i) f(ba + std::size_t(i), bb + std::size_t(i));
  }
}

//! Per-sensor buffers of a test: tile scratch and ray norms for images up to 640 x 480.
template <class Real>
struct SensorBuffers {
  static constexpr std::size_t kTiles = edgefuse::FrameScratch::tiles_for(640, 480);
  edgefuse::DepthTile depth_tiles[kTiles];
  Real norms[640 * 480];
  edgefuse::FrameScratch scratch() {
    edgefuse::FrameScratch f;
    f.depth_tiles = depth_tiles;
    f.capacity = kTiles;
    return f;
  }
  edgefuse::ImageView<const Real> ray_norms(const edgefuse::PinholeIntrinsics& c) {
    edgefuse::build_ray_norms<Real>(c, edgefuse::ImageView<Real>(norms, c.width, c.height));
    return edgefuse::ImageView<const Real>(norms, c.width, c.height);
  }
};

}  // namespace edgefuse_test
