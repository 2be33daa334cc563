// The static memory map: every large buffer, its size, derived from a board's capacities.
// The same table sizes the arena at compile time (checked against the board's RAM budget),
// carves it at start-up and is printed by `edgefuse memmap --board NAME`.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"
#include "edgefuse/core/status.hpp"
#include "edgefuse/math/pose.hpp"
#include "edgefuse/localize/localizer.hpp"  // localisation
#include "edgefuse/memory/acquisition_pools.hpp"
#include "edgefuse/memory/capacities.hpp"
#include "edgefuse/tracking/icp.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/frame_scratch.hpp"
#include "edgefuse/tsdf/raycast.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

enum class Region : int {
  kVoxelTsdf,
  kVoxelWeight,
  kVoxelColour,
  kVoxelColourWeight,
  kBrickSlots,
  kBrickFlags,
  kBrickList,
  kDepthFrames,     //!< raw depth per sensor (uint16)
  kColourFrames,    //!< registered RGB per sensor
  kRayNorms,        //!< |ray| per pixel per sensor
  kRaycastDepth,    //!< model depth per sensor (float)
  kRaycastVertex,   //!< model vertices per sensor
  kRaycastNormal,   //!< model normals per sensor
  kRaycastColour,   //!< model colour per sensor
  kDepthTiles,      //!< 8x8-pixel depth bounds per sensor (integration)
  kSurfacePoints,   //!< extracted / fused cloud
  kMeshScratch,     //!< marching-cubes slice tables
  kPyramidVertex,   //!< tracking: the frame's vertex maps, all pyramid levels, per sensor
  kPyramidNormal,   //!< tracking: the frame's normal maps, all pyramid levels, per sensor
  kIcpRowSums,      //!< tracking: ICP per-row partial sums per sensor
  // multi-sensor fusion
  kTrustMaps,       //!< per-pixel trust (uint8, 1/255) from each sensor's noise model
  // localisation
  kLocModels,       //!< model descriptions
  kLocModelPoints,  //!< dense model samples
  kLocPpfPoints,    //!< sparse model samples (PPF)
  kLocPpfEntries,   //!< PPF hash table entries
  kLocPpfBuckets,   //!< PPF hash table bucket offsets
  kLocScene,        //!< scene points (bin removed)
  kLocScratch,      //!< sort keys (subsampling)
  kLocGridIndex,    //!< scene grid: point indices by cell
  kLocGridBuckets,  //!< scene grid: bucket offsets
  kLocGridNear,     //!< scene grid: buckets with a scene point within one cell
  kLocGridPoints,   //!< scene grid: point positions by cell
  kLocSample,       //!< subsampled scene indices
  kLocLabels,       //!< per scene point: claim / segment label
  kLocQueue,        //!< region growing queue
  kLocVotes,        //!< PPF vote accumulator
  kLocCandidates,   //!< pose candidates (vote peaks)
  kLocVerified,     //!< refined, verified hypotheses
  kLocResults,      //!< the pose list
  // raycast: per-brick block masks
  kBlockMasks,      //!< per brick: which of its 64 blocks of 2^3 voxels hold a distance < +1
  // acquisition frame pools (HAL): kFramePoolSlots frames per sensor, filled by the
  // device threads and handed to processing (edgefuse/hal/acquisition/frame_pool.hpp)
  kAcqDepth,        //!< pooled depth (uint16)
  kAcqColour,       //!< pooled registered colour
  kAcqAmplitude,    //!< pooled ToF amplitude (uint16)
  // line-scanner profile pool: kProfilePoolSlots profiles of the line scanner's thread
  kAcqProfiles,     //!< pooled profile ranges (float)
  kCount
};

struct MemoryRegion {
  const char* name;
  uint64_t bytes;
};

struct MemoryMap {
  MemoryRegion regions[int(Region::kCount)];
  uint64_t total_bytes;  //!< including alignment padding
};

inline constexpr std::size_t kRegionAlign = 64;  //!< every region starts on a cache line

constexpr uint64_t align_up(uint64_t v, uint64_t a) { return (v + a - 1) / a * a; }

//! The memory map of a board.
constexpr MemoryMap make_memory_map(const BoardCapacities& c) {
  const uint64_t cube_voxels = uint64_t(c.volume_dim) * c.volume_dim * c.volume_dim;
  const uint64_t bricks = cube_voxels / kBrickVoxels;        // of the cube the index covers
  const uint64_t voxels = uint64_t(c.pool_bricks) * kBrickVoxels;  // of the voxel pool
  const uint64_t pixels = uint64_t(c.image_width_max) * c.image_height_max * c.sensors_max;
  const uint64_t tiles = uint64_t(FrameScratch::tiles_for(c.image_width_max, c.image_height_max)) * c.sensors_max;
  MemoryMap m{};
  auto set = [&m](Region r, const char* name, uint64_t bytes) { m.regions[int(r)] = MemoryRegion{name, bytes}; };
  set(Region::kVoxelTsdf, "voxel tsdf (int16)", voxels * sizeof(int16_t));
  set(Region::kVoxelWeight, "voxel weight (uint8)", voxels * sizeof(uint8_t));
  set(Region::kVoxelColour, "voxel colour (3 x uint8)", c.colour ? voxels * sizeof(Rgb8) : 0);
  set(Region::kVoxelColourWeight, "voxel colour weight (uint8)", c.colour ? voxels : 0);
  set(Region::kBrickSlots, "brick index (pool slots)", bricks * sizeof(uint32_t));
  set(Region::kBrickFlags, "brick flags", bricks);
  set(Region::kBrickList, "brick work list", bricks * sizeof(uint32_t));
  set(Region::kDepthFrames, "depth frames", pixels * sizeof(uint16_t));
  set(Region::kColourFrames, "colour frames", pixels * sizeof(Rgb8));
  set(Region::kRayNorms, "ray norm maps", pixels * sizeof(float));
  set(Region::kRaycastDepth, "raycast depth", pixels * sizeof(float));
  set(Region::kRaycastVertex, "raycast vertex", pixels * sizeof(Vec3f));
  set(Region::kRaycastNormal, "raycast normal", pixels * sizeof(Vec3f));
  set(Region::kRaycastColour, "raycast colour", pixels * sizeof(Rgba8));
  set(Region::kDepthTiles, "depth tile bounds", tiles * sizeof(DepthTile));
  set(Region::kSurfacePoints, "surface points", uint64_t(c.points_max) * sizeof(SurfacePoint));
  set(Region::kMeshScratch, "mesh slice tables",
      uint64_t(MeshScratch::entries_for(c.volume_dim)) * sizeof(uint32_t));
  const uint64_t pyramid = uint64_t(pyramid_pixels(c.image_width_max, c.image_height_max)) * c.sensors_max;
  set(Region::kPyramidVertex, "frame pyramid vertices", pyramid * sizeof(Point3<float>));
  set(Region::kPyramidNormal, "frame pyramid normals", pyramid * sizeof(Point3<float>));
  set(Region::kIcpRowSums, "icp row sums", uint64_t(c.image_height_max) * kIcpRowBytes * c.sensors_max);
  // multi-sensor fusion
  set(Region::kTrustMaps, "trust maps (uint8)", pixels * sizeof(uint8_t));
  // localisation
  const uint64_t mm = uint64_t(c.models_max);
  set(Region::kLocModels, "loc models", mm * sizeof(ModelInfo));
  set(Region::kLocModelPoints, "loc model samples", mm * c.model_points_max * sizeof(OrientedPoint));
  set(Region::kLocPpfPoints, "loc ppf samples", mm * c.ppf_points_max * sizeof(OrientedPoint));
  set(Region::kLocPpfEntries, "loc ppf table",
      mm * c.ppf_points_max * (c.ppf_points_max > 0 ? c.ppf_points_max - 1 : 0) * sizeof(PpfEntry));
  set(Region::kLocPpfBuckets, "loc ppf buckets", mm * (kPpfBuckets + 1) * sizeof(uint32_t));
  set(Region::kLocScene, "loc scene points", uint64_t(c.scene_points_max) * sizeof(ScenePoint));
  set(Region::kLocScratch, "loc sort keys", uint64_t(c.scene_points_max) * 2 * sizeof(uint64_t));
  set(Region::kLocGridIndex, "loc grid index", uint64_t(c.scene_points_max) * sizeof(uint32_t));
  set(Region::kLocGridBuckets, "loc grid buckets", uint64_t(kGridBuckets + 1) * sizeof(uint32_t));
  set(Region::kLocGridNear, "loc grid near bits", uint64_t(kGridBuckets / 64) * sizeof(uint64_t));
  set(Region::kLocGridPoints, "loc grid points", uint64_t(c.scene_points_max) * sizeof(Vec3f));
  set(Region::kLocSample, "loc scene sample", uint64_t(c.scene_points_max) * sizeof(uint32_t));
  set(Region::kLocLabels, "loc labels", uint64_t(c.scene_points_max) * sizeof(int32_t));
  set(Region::kLocQueue, "loc queue", uint64_t(c.scene_points_max) * sizeof(uint32_t));
  // one accumulator per vote chunk (parallel PPF voting)
  set(Region::kLocVotes, "loc votes", uint64_t(kVoteAccumulators) * c.ppf_points_max * kPpfAngleBins * sizeof(uint16_t));
  set(Region::kLocCandidates, "loc pose candidates", uint64_t(c.hypotheses_max) * sizeof(PoseCandidate));
  set(Region::kLocVerified, "loc verified hypotheses", mm * kClustersPerModel * sizeof(LocalizedObject));
  set(Region::kLocResults, "loc pose list", uint64_t(c.objects_max) * sizeof(LocalizedObject));
  set(Region::kBlockMasks, "brick block masks", bricks * sizeof(uint64_t));  // raycast: per-brick block masks
  // acquisition frame pools (HAL)
  const uint64_t pooled = pixels * uint64_t(kFramePoolSlots);
  set(Region::kAcqDepth, "acquisition pools: depth", pooled * sizeof(uint16_t));
  set(Region::kAcqColour, "acquisition pools: colour", pooled * sizeof(Rgb8));
  set(Region::kAcqAmplitude, "acquisition pools: amplitude", pooled * sizeof(uint16_t));
  // line-scanner profile pool
  set(Region::kAcqProfiles, "acquisition pools: line profiles",
      uint64_t(c.image_width_max) * uint64_t(kProfilePoolSlots) * sizeof(float));
  uint64_t total = 0;
  for (const MemoryRegion& r : m.regions) total += align_up(r.bytes, kRegionAlign);
  m.total_bytes = total;
  return m;
}

//! Views of every region of one board's arena, carved once at start-up.
struct CoreBuffers {
  VoxelStorage voxels;
  uint16_t* depth_frames = nullptr;   //!< sensors_max images of image_*_max
  Rgb8* colour_frames = nullptr;
  float* ray_norms = nullptr;         //!< float or Fixed (both 4 bytes)
  float* raycast_depth = nullptr;
  Vec3f* raycast_vertex = nullptr;
  Vec3f* raycast_normal = nullptr;
  Rgba8* raycast_colour = nullptr;
  DepthTile* depth_tiles = nullptr;
  SurfacePoint* points = nullptr;
  MeshScratch mesh_scratch;
  void* pyramid_vertex = nullptr;     //!< Point3<float> or Point3<Fixed> (both 12 bytes)
  void* pyramid_normal = nullptr;     //!< the same
  void* icp_rows = nullptr;           //!< IcpSums of either build, kIcpRowBytes per row
  uint8_t* trust_maps = nullptr;      //!< sensors_max trust maps of image_*_max (multi-sensor fusion)
  LocalizeBuffers localize;           //!< localisation tables
  FramePoolBuffers frame_pools;       //!< acquisition frame pools (HAL)
  ProfilePoolBuffers profile_pool;    //!< the line scanner's profile pool
  std::size_t pixels_per_sensor = 0;  //!< stride between the sensors' images in each region
  std::size_t tiles_per_sensor = 0;   //!< stride between the sensors' tile arrays
  std::size_t pyramid_points_per_sensor = 0;  //!< points of one sensor's pyramid map (all levels)
  std::size_t icp_row_bytes_per_sensor = 0;   //!< bytes of one sensor's ICP row sums

  //! The frame pyramid of sensor i, bound to intr (kCapacityExceeded when it does not fit).
  template <class Real>
  Status pyramid(int sensor, const PinholeIntrinsics& intr, FramePyramid<Real>& out) const {
    auto* base_v = static_cast<Point3<Real>*>(pyramid_vertex) + std::size_t(sensor) * pyramid_points_per_sensor;
    auto* base_n = static_cast<Point3<Real>*>(pyramid_normal) + std::size_t(sensor) * pyramid_points_per_sensor;
    return bind_pyramid<Real>(intr, base_v, base_n, pyramid_points_per_sensor, out);
  }
  //! The ICP row sums of sensor i.
  template <class Real>
  IcpWorkspace<Real> icp_workspace(int sensor) const {
    return IcpWorkspace<Real>::bind(static_cast<uint8_t*>(icp_rows) + std::size_t(sensor) * icp_row_bytes_per_sensor,
                                    icp_row_bytes_per_sensor);
  }

  //! The raycast maps of sensor i, width x height (<= the board's largest image).
  //! \param colour bind the colour map too (boards that fuse colour; else it stays empty)
  RaycastMaps raycast_maps(int sensor, int width, int height, bool colour) const {
    const std::size_t off = std::size_t(sensor) * pixels_per_sensor;
    RaycastMaps m;
    m.depth_m = ImageView<float>(raycast_depth + off, width, height);
    m.vertex = ImageView<Vec3f>(raycast_vertex + off, width, height);
    m.normal = ImageView<Vec3f>(raycast_normal + off, width, height);
    if (colour && raycast_colour != nullptr) m.colour = ImageView<Rgba8>(raycast_colour + off, width, height);
    return m;
  }

  //! The tile scratch of sensor i (0 <= i < sensors_max).
  FrameScratch scratch(int sensor) const {
    FrameScratch f;
    f.depth_tiles = depth_tiles + std::size_t(sensor) * tiles_per_sensor;
    f.capacity = tiles_per_sensor;
    return f;
  }
};

//! Splits `arena` (at least make_memory_map(c).total_bytes, 64-byte aligned) into the regions.
//! \param c the board's capacities
//! \param arena base of the static arena
//! \param arena_bytes its size
//! \param out views of the regions
Status carve_memory(const BoardCapacities& c, uint8_t* arena, uint64_t arena_bytes, CoreBuffers& out);

}  // namespace edgefuse
