#include "edgefuse/memory/memmap.hpp"

namespace edgefuse {

Status carve_memory(const BoardCapacities& c, uint8_t* arena, uint64_t arena_bytes, CoreBuffers& out) {
  const MemoryMap map = make_memory_map(c);
  if (arena == nullptr || arena_bytes < map.total_bytes) return Status::kCapacityExceeded;
  if (reinterpret_cast<uintptr_t>(arena) % kRegionAlign != 0) return Status::kInvalidArgument;
  void* base[int(Region::kCount)] = {};
  uint64_t offset = 0;
  for (int i = 0; i < int(Region::kCount); ++i) {
    base[i] = map.regions[i].bytes ? arena + offset : nullptr;
    offset += align_up(map.regions[i].bytes, kRegionAlign);
  }
  auto at = [&base](Region r) { return base[int(r)]; };
  out = CoreBuffers{};
  out.voxels.tsdf = static_cast<int16_t*>(at(Region::kVoxelTsdf));
  out.voxels.weight = static_cast<uint8_t*>(at(Region::kVoxelWeight));
  out.voxels.colour = static_cast<Rgb8*>(at(Region::kVoxelColour));
  out.voxels.colour_weight = static_cast<uint8_t*>(at(Region::kVoxelColourWeight));
  out.voxels.brick_slot = static_cast<uint32_t*>(at(Region::kBrickSlots));
  out.voxels.brick_flags = static_cast<uint8_t*>(at(Region::kBrickFlags));
  out.voxels.brick_list = static_cast<uint32_t*>(at(Region::kBrickList));
  out.voxels.block_mask = static_cast<uint64_t*>(at(Region::kBlockMasks));  // raycast: per-brick block masks
  out.voxels.capacity_dim = c.volume_dim;
  out.voxels.pool_bricks = c.pool_bricks;
  out.depth_frames = static_cast<uint16_t*>(at(Region::kDepthFrames));
  out.colour_frames = static_cast<Rgb8*>(at(Region::kColourFrames));
  out.ray_norms = static_cast<float*>(at(Region::kRayNorms));
  out.raycast_depth = static_cast<float*>(at(Region::kRaycastDepth));
  out.raycast_vertex = static_cast<Vec3f*>(at(Region::kRaycastVertex));
  out.raycast_normal = static_cast<Vec3f*>(at(Region::kRaycastNormal));
  out.raycast_colour = static_cast<Rgba8*>(at(Region::kRaycastColour));
  out.depth_tiles = static_cast<DepthTile*>(at(Region::kDepthTiles));
  out.points = static_cast<SurfacePoint*>(at(Region::kSurfacePoints));
  out.mesh_scratch.edge_ids = static_cast<uint32_t*>(at(Region::kMeshScratch));
  out.mesh_scratch.capacity = MeshScratch::entries_for(c.volume_dim);
  out.pyramid_vertex = at(Region::kPyramidVertex);
  out.pyramid_normal = at(Region::kPyramidNormal);
  out.icp_rows = at(Region::kIcpRowSums);
  out.trust_maps = static_cast<uint8_t*>(at(Region::kTrustMaps));  // multi-sensor fusion
  // localisation
  LocalizeBuffers& l = out.localize;
  l.models = static_cast<ModelInfo*>(at(Region::kLocModels));
  l.model_points = static_cast<OrientedPoint*>(at(Region::kLocModelPoints));
  l.ppf_points = static_cast<OrientedPoint*>(at(Region::kLocPpfPoints));
  l.ppf_entries = static_cast<PpfEntry*>(at(Region::kLocPpfEntries));
  l.ppf_buckets = static_cast<uint32_t*>(at(Region::kLocPpfBuckets));
  l.scene = static_cast<ScenePoint*>(at(Region::kLocScene));
  l.scratch = static_cast<uint64_t*>(at(Region::kLocScratch));
  l.grid_index = static_cast<uint32_t*>(at(Region::kLocGridIndex));
  l.grid_buckets = static_cast<uint32_t*>(at(Region::kLocGridBuckets));
  l.grid_near = static_cast<uint64_t*>(at(Region::kLocGridNear));
  l.grid_points = static_cast<Vec3f*>(at(Region::kLocGridPoints));
  l.sample = static_cast<uint32_t*>(at(Region::kLocSample));
  l.labels = static_cast<int32_t*>(at(Region::kLocLabels));
  l.queue = static_cast<uint32_t*>(at(Region::kLocQueue));
  l.votes = static_cast<uint16_t*>(at(Region::kLocVotes));
  l.candidates = static_cast<PoseCandidate*>(at(Region::kLocCandidates));
  l.verified = static_cast<LocalizedObject*>(at(Region::kLocVerified));
  l.results = static_cast<LocalizedObject*>(at(Region::kLocResults));
  l.models_max = c.models_max;
  l.model_points_max = c.model_points_max;
  l.ppf_points_max = c.ppf_points_max;
  l.scene_points_max = c.scene_points_max;
  l.hypotheses_max = c.hypotheses_max;
  l.objects_max = c.objects_max;
  // acquisition frame pools (HAL)
  out.frame_pools.depth = static_cast<uint16_t*>(at(Region::kAcqDepth));
  out.frame_pools.colour = static_cast<Rgb8*>(at(Region::kAcqColour));
  out.frame_pools.amplitude = static_cast<uint16_t*>(at(Region::kAcqAmplitude));
  out.frame_pools.pixels_per_slot = std::size_t(c.image_width_max) * std::size_t(c.image_height_max);
  out.frame_pools.slots = kFramePoolSlots;
  out.frame_pools.pools = c.sensors_max;
  // line-scanner profile pool
  out.profile_pool.ranges_m = static_cast<float*>(at(Region::kAcqProfiles));
  out.profile_pool.beams_max = c.image_width_max;
  out.profile_pool.slots = kProfilePoolSlots;
  out.pyramid_points_per_sensor = pyramid_pixels(c.image_width_max, c.image_height_max);
  out.icp_row_bytes_per_sensor = std::size_t(c.image_height_max) * kIcpRowBytes;
  out.pixels_per_sensor = std::size_t(c.image_width_max) * std::size_t(c.image_height_max);
  out.tiles_per_sensor = FrameScratch::tiles_for(c.image_width_max, c.image_height_max);
  return Status::kOk;
}

}  // namespace edgefuse
